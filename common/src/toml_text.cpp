#include "common/toml_text.hpp"

#include <sstream>

#include "common/number_text.hpp"

namespace alc::common {

std::string toml_value_text(const toml::node* node) {
  if (!node) return "";
  if (const auto* s = node->as_string()) return "\"" + s->get() + "\"";
  if (const auto* f = node->as_floating_point()) return shortest_text(f->get());
  if (const auto* i = node->as_integer()) {
    if (i->flags() == toml::value_flags::none) return std::to_string(i->get());
    std::ostringstream o;  // hex, octal or binary: as written (0x10, not 16)
    o << *i;
    return o.str();
  }
  if (const auto* b = node->as_boolean()) return b->get() ? "true" : "false";
  if (const auto* a = node->as_array()) {
    std::string text = "[";
    for (std::size_t k = 0; k < a->size(); ++k) text += (k ? ", " : "") + toml_value_text(a->get(k));
    return text + "]";
  }
  std::ostringstream o;  // tables, dates and times: as toml++ writes them
  node->visit([&o](const auto& n) { o << n; });
  return o.str();
}

std::string toml_syntax_error(const std::string& file, const toml::parse_error& e) {
  const auto& at = e.source().begin;
  return file + ":" + std::to_string(at.line) + ":" + std::to_string(at.column) + ": " + std::string(e.description());
}

}  // namespace alc::common
