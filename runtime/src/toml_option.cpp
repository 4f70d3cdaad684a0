#include "runtime/toml_option.hpp"

#include <cmath>
#include <stdexcept>

#include "common/number_text.hpp"
#include "runtime/parameter_options.hpp"

namespace alc::runtime {

std::string option_text_of(std::string_view option, const toml::node& node) {
  if (const auto* i = node.as_integer()) {
    if (i->flags() != toml::value_flags::none)
      throw std::invalid_argument("write it in decimal digits (hex, octal and binary integers are not taken)");
    return std::to_string(i->get());
  }
  if (const auto* f = node.as_floating_point()) return common::shortest_text(f->get());
  if (const auto* s = node.as_string()) {
    const ParameterOption* o = find_parameter_option(option);
    const bool numeric = o && o->domain != Domain::Choice && o->domain != Domain::Flag;
    if (!numeric) return s->get();
    try {
      const double v = common::parse_number(option, s->get(), true);
      return std::isinf(v) ? "inf" : common::shortest_text(v);
    } catch (const std::invalid_argument&) {
      return s->get();  // a malformed number: the option's own check names it as written
    }
  }
  if (const auto* b = node.as_boolean()) return b->get() ? "true" : "false";
  throw std::invalid_argument("a value must be a number, a string or true/false");
}

}  // namespace alc::runtime
