#include <catch2/catch.hpp>
#include <string>

#include "common/strict_json.hpp"
#include "common/utf8.hpp"

using alc::common::JsonTextError;
using alc::common::parse_json_text;

namespace {
JsonTextError refusal(const std::string& text) {
  try {
    parse_json_text(text);
  } catch (const JsonTextError& e) {
    return e;
  }
  FAIL("accepted: " << text);
  return JsonTextError(0, "", "");
}
}  // namespace

TEST_CASE("strict JSON: the same key in two objects is fine, twice in one object is refused, at any depth") {
  const auto j = parse_json_text(R"({"a": {"x": 1}, "b": {"x": 2}, "c": [{"x": 3}, {"x": 4}]})");
  CHECK(j["b"]["x"] == 2);
  CHECK(j["c"][1]["x"] == 4);
  auto e = refusal(R"({"a": 1, "b": 2, "a": 3})");
  CHECK(e.key == "a");
  CHECK(std::string(e.what()) == "duplicate key 'a'");
  e = refusal(R"({"a": {"y": 1}, "c": [{"x": 3, "x": 4}]})");
  CHECK(e.key == "x");
}

TEST_CASE("strict JSON: a syntax error says the column in the text, without the library's prefix") {
  auto e = refusal(R"({"a": tru})");
  CHECK(e.key.empty());
  CHECK(e.column == 10);  // the "}" that ends the literal "tru"
  CHECK_THAT(e.what(), Catch::StartsWith("at column 10: syntax error while parsing value"));
  CHECK(std::string(e.what()).find("json.exception") == std::string::npos);
  CHECK(std::string(e.what()).find("line 1") == std::string::npos);
  e = refusal(R"({"a": 1e999})");
  CHECK(e.column == 0);
  CHECK(std::string(e.what()) == "number overflow parsing '1e999'");
  e = refusal("");
  CHECK(e.column == 1);
}

TEST_CASE("strict JSON: a huge token is quoted shortened, with its length") {
  // Before: a 5000-digit number was quoted whole in the message (5 MB for a 5 MB token).
  const auto e = refusal("{\"a\": " + std::string(5000, '1') + "}");
  const std::string what = e.what();
  CHECK(what.size() < 300);
  CHECK_THAT(what, Catch::StartsWith("number overflow parsing '1111") && Catch::Contains("(5026 characters in all)"));
}

TEST_CASE("valid_utf8: bytes outside a valid UTF-8 sequence become hex escapes, valid text is kept") {
  using alc::common::valid_utf8;
  CHECK(valid_utf8("T_WS °C é ✓ 𝄞") == "T_WS °C é ✓ 𝄞");
  CHECK(valid_utf8("T_\xE9") == "T_\\xE9");                // Latin-1 é
  CHECK(valid_utf8("\xFF{}") == "\\xFF{}");
  CHECK(valid_utf8("\xC0\xAF") == "\\xC0\\xAF");           // overlong '/'
  CHECK(valid_utf8("\xED\xA0\x80") == "\\xED\\xA0\\x80");  // a surrogate
  CHECK(valid_utf8("\xE2\x9C") == "\\xE2\\x9C");           // cut short
  CHECK(valid_utf8("\xF4\x90\x80\x80") == "\\xF4\\x90\\x80\\x80");  // beyond U+10FFFF
}
