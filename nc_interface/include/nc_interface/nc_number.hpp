#pragma once
// The one place that formats numbers for NC code.
#include <string>

namespace alc::nc {

enum class SignStyle {
  NegativeOnly,  // "0.0123", "-0.0040" (RS274NGC, Fanuc, Sinumerik)
  Always,        // "+0.0123", "-0.0040", "+0.0000" (Heidenhain Klartext)
};

// Largest magnitude accepted [mm] or [°]: beyond this a value is a bug, not an offset.
inline constexpr double kMaxNcMagnitude = 1e6;
// A base work offset's bound and a compensation limit's (max_offset, max_step): their sum always
// prints (G10 L2 writes base + compensation).
inline constexpr double kMaxBase = 1e5;           // [mm] or [deg]
inline constexpr double kMaxCompensation = 1000;  // [mm] or [deg]

// Fixed point with exactly four decimals (the NC resolution 0.0001 mm / 0.0001°), never exponent
// notation, never "-0.0000". Rounding: the shortest decimal text that reads back to the same double
// (std::to_chars, what the JSON lines show) is rounded at the fourth decimal, halves away from zero:
// 0.00005 -> "0.0001", -0.00005 -> "-0.0001", 0.00015 -> "0.0002" (although its binary value is
// a little below), -0.00004 -> "0.0000". Throws std::domain_error for NaN, ±inf or a magnitude
// above kMaxNcMagnitude.
std::string format_nc_number(double value, SignStyle sign = SignStyle::NegativeOnly);

// The NC resolution: 0.0001 mm / 0.0001°, 10^4 ticks per unit.
inline constexpr double kNcTicksPerUnit = 1e4;
// The value format_nc_number(value) prints, in ticks of the NC resolution (0.00015 -> 2). Throws
// like format_nc_number.
long long nc_ticks(double value);
// The double nearest the printed decimal (nc_ticks(value) / 1e4): what the NC holds after reading
// the text; format_nc_number of it prints the same text.
double as_printed(double value);
// A work offset written as base + compensation (G10 L2): the printed base plus the printed
// compensation, so that the compensation the NC holds is exactly the one the safety gate judged.
double with_base(double base, double offset);

}  // namespace alc::nc
