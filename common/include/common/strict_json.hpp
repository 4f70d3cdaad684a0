#pragma once
// The one strict reader of a JSON text that a user or a peer hands us (a line of NC commands, an MQTT
// payload). nlohmann::json alone lets the last of two equal keys win without a word and words its
// errors with its own "[json.exception...] ... line 1, column 7" prefix; this reader refuses a
// duplicate key and says where the text breaks in the caller's terms.
#include <cstddef>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <string_view>

namespace alc::common {

struct JsonTextError : std::runtime_error {
  // column: 1-based character of the text where it breaks, 0 where the parser does not say (a number
  // too large for a double); key: the duplicated key, empty for other errors.
  JsonTextError(std::size_t column, std::string key, const std::string& reason);
  std::size_t column;
  std::string key;
  std::string reason;  // e.g. "syntax error while parsing value - invalid literal; last read: 'x'"
};

// The JSON value of `text`. Throws JsonTextError: not JSON (what(): "at column N: <reason>"), a number
// beyond a double ("number overflow parsing '1e999'"), or a key given twice in one object (what():
// "duplicate key 'x'").
nlohmann::json parse_json_text(std::string_view text);

}  // namespace alc::common
