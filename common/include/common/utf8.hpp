#pragma once
// UTF-8 as the project meets it in outside text (a CSV header, an MQTT payload, a JSON token): one
// decoder of well-formed sequences, and the one way to show bytes that are not.
#include <cstddef>
#include <string>
#include <string_view>

namespace alc::common {

// The length of the well-formed UTF-8 sequence at text[i] (1…4), or 0 if it is not one (a stray
// continuation byte, a truncated or overlong sequence, a surrogate, beyond U+10FFFF).
std::size_t utf8_length(std::string_view text, std::size_t i);

// The byte offset of the first byte that is not well-formed UTF-8, or npos.
std::size_t invalid_utf8_at(std::string_view text);

// `text` with every byte that is not part of a well-formed UTF-8 sequence as the four characters \xNN
// (and, with `controls`, every control character too: a NUL, a stray CR), so that a message quoting
// outside bytes names them, on one line, and writing it as JSON never throws (nlohmann::json::dump()
// throws on invalid UTF-8). Valid text without controls comes back as it is.
std::string escaped_utf8(std::string_view text, bool controls = false);

// `text` if it is at most `max` bytes, else its first `max` bytes or fewer, cut between two UTF-8
// characters, with "…" after: a long value quoted in a message.
std::string shortened(std::string_view text, std::size_t max);

// escaped_utf8(text): text a JSON string can carry.
inline std::string valid_utf8(std::string_view text) { return escaped_utf8(text, false); }

}  // namespace alc::common
