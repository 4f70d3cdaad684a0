#pragma once
// A TOML value given for a controller option (a study grid's value, a key of the supervisor's
// [controller]) as the text the option takes on the command line: the one conversion both use.
#include <string>
#include <string_view>
#include <toml++/toml.h>

namespace alc::runtime {

// Integers in decimal, floats in their shortest form; a string that is a number, for an option that
// takes numbers, is that number in its shortest form ("6.50" is "6.5", "Inf" is "inf"), so that equal
// values compare equal; other strings as written; booleans "true"/"false". Throws std::invalid_argument
// (the reason alone) for a hex, octal or binary integer (the options refuse "0x10" too) and for a value
// that is none of these (a table, an array, a date).
std::string option_text_of(std::string_view option, const toml::node& node);

}  // namespace alc::runtime
