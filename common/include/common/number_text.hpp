#pragma once
// The one place that turns a double into the shortest decimal text that reads back to the same
// double (std::to_chars without a precision). CSV writers and the history export use it, each with
// its own rule for the values that a file cannot hold as a number (NaN as an empty cell, say).
#include <cstdint>
#include <string>
#include <string_view>

namespace alc::common {

// Shortest round-trip text of `value`: std::from_chars (and std::stod) read it back bit for bit,
// -0.0 included ("-0"). Exponent form only where it is shorter ("1e-12", "1.5e+300"). Not numbers:
// "inf", "-inf", and "nan" for every NaN (sign and payload are not kept).
std::string shortest_text(double value);

// The one strict reader of numbers given as text by a user (command-line options, a study grid's
// values). A decimal number >= 0: digits, an optional fraction and exponent, nothing else ("6.5",
// ".5", "1e3"); no sign, no hex ("0x10"), no "nan"; "inf" (or "Inf") only when allow_inf. Throws
// std::invalid_argument "<what>: '<text>' is not a number >= 0[ or inf]", or "... is out of the range
// of a double" for a number that underflows or overflows (1e-400, 1e999).
double parse_number(std::string_view what, std::string_view text, bool allow_inf);

// A whole number from lo to hi, decimal digits only (no sign, fraction, exponent or blank). Throws
// std::invalid_argument "<what>: '<text>' is not a whole number from <lo> to <hi>".
std::uint64_t parse_whole_number(std::string_view what, std::string_view text, std::uint64_t lo, std::uint64_t hi);

}  // namespace alc::common
