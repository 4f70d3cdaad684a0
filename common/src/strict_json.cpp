#include "common/strict_json.hpp"

#include <set>
#include <vector>

#include "common/utf8.hpp"

namespace alc::common {

namespace {
std::string what_of(std::size_t column, const std::string& key, const std::string& reason) {
  if (!key.empty()) return "duplicate key '" + key + "'";
  return column ? "at column " + std::to_string(column) + ": " + reason : reason;
}

// nlohmann's message without its "[json.exception.<kind>.<id>] " and "parse error at line 1, column
// N: " prefixes (one line of text: the column is the caller's to say).
std::string bare_reason(const std::string& what) {
  std::string r = what;
  if (r.rfind("[json.exception.", 0) == 0)
    if (const auto end = r.find("] "); end != std::string::npos) r.erase(0, end + 2);
  if (r.rfind("parse error", 0) == 0)
    if (const auto colon = r.find(": "); colon != std::string::npos) r.erase(0, colon + 2);
  // nlohmann quotes the whole token: a 5 MB number would be a 5 MB message.
  constexpr std::size_t kLongest = 240;
  if (r.size() > kLongest) r = shortened(r, kLongest - 80) + " (" + std::to_string(r.size()) + " characters in all)";
  return r;
}
}  // namespace

JsonTextError::JsonTextError(std::size_t column_, std::string key_, const std::string& reason_)
    : std::runtime_error(what_of(column_, key_, reason_)), column(column_), key(std::move(key_)), reason(reason_) {}

nlohmann::json parse_json_text(std::string_view text) {
  using nlohmann::json;
  std::vector<std::set<std::string>> keys;  // per open object the keys seen so far
  const json::parser_callback_t check = [&keys](int, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start: keys.emplace_back(); break;
      case json::parse_event_t::object_end: keys.pop_back(); break;
      case json::parse_event_t::key: {
        const auto& k = parsed.get_ref<const std::string&>();
        if (!keys.back().insert(k).second) throw JsonTextError(0, k, "duplicate key");
        break;
      }
      default: break;
    }
    return true;
  };
  try {
    return json::parse(text.begin(), text.end(), check);
  } catch (const json::parse_error& e) {
    throw JsonTextError(e.byte, "", bare_reason(e.what()));
  } catch (const json::exception& e) {  // out_of_range.406: a number beyond a double
    throw JsonTextError(0, "", bare_reason(e.what()));
  }
}

}  // namespace alc::common
