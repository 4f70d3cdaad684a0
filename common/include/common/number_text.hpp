#pragma once
// The one place that turns a double into the shortest decimal text that reads back to the same
// double (std::to_chars without a precision). CSV writers and the history export use it, each with
// its own rule for the values that a file cannot hold as a number (NaN as an empty cell, say).
#include <string>

namespace alc::common {

// Shortest round-trip text of `value`: std::from_chars (and std::stod) read it back bit for bit,
// -0.0 included ("-0"). Exponent form only where it is shorter ("1e-12", "1.5e+300"). Not numbers:
// "inf", "-inf", and "nan" for every NaN (sign and payload are not kept).
std::string shortest_text(double value);

}  // namespace alc::common
