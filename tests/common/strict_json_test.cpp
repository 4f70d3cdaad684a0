#include <catch2/catch.hpp>
#include <string>

#include "common/strict_json.hpp"

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
