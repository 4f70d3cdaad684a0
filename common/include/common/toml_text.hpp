#pragma once
// A TOML value as a message shows it: as the user could have typed it. Numbers in their shortest
// form (common::shortest_text: -0.1, not toml++'s -0.10000000000000001), strings quoted, arrays
// element by element ("[0, 0, 0]"), empty for a missing value.
#include <string>
#include <toml++/toml.h>

namespace alc::common {

std::string toml_value_text(const toml::node* node);

// A TOML syntax error as every config reader reports it: "<file>:<line>:<column>: <toml++'s description>".
std::string toml_syntax_error(const std::string& file, const toml::parse_error& e);

}  // namespace alc::common
