#include <bit>
#include <catch2/catch.hpp>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>

#include "common/number_text.hpp"

using alc::common::shortest_text;

namespace {

double read_back(const std::string& text) {
  double value = 0.0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  REQUIRE(ec == std::errc{});
  REQUIRE(ptr == text.data() + text.size());
  return value;
}

}  // namespace

TEST_CASE("shortest_text: hand-checked forms") {
  CHECK(shortest_text(0.0) == "0");
  CHECK(shortest_text(-0.0) == "-0");
  CHECK(shortest_text(0.1) == "0.1");
  CHECK(shortest_text(-12.5) == "-12.5");
  CHECK(shortest_text(100.0) == "100");
  CHECK(shortest_text(1e-12) == "1e-12");
  CHECK(shortest_text(1.0 / 3.0) == "0.3333333333333333");
  CHECK(shortest_text(std::numeric_limits<double>::infinity()) == "inf");
  CHECK(shortest_text(-std::numeric_limits<double>::infinity()) == "-inf");
  CHECK(shortest_text(std::numeric_limits<double>::quiet_NaN()) == "nan");
  CHECK(shortest_text(-std::numeric_limits<double>::quiet_NaN()) == "nan");
  CHECK(shortest_text(std::numeric_limits<double>::lowest()) == "-1.7976931348623157e+308");
  CHECK(shortest_text(std::numeric_limits<double>::denorm_min()) == "5e-324");
}

TEST_CASE("shortest_text: reads back bit for bit, random doubles of every exponent (seed 20240609)") {
  std::mt19937_64 rng(20240609);
  int checked = 0;
  for (int i = 0; i < 200000; ++i) {
    const double value = std::bit_cast<double>(rng());  // every bit pattern: all exponents, denormals
    if (!std::isfinite(value)) continue;
    const std::string text = shortest_text(value);
    const double back = read_back(text);
    if (std::bit_cast<std::uint64_t>(back) != std::bit_cast<std::uint64_t>(value)) FAIL("text " << text);
    ++checked;
  }
  CHECK(checked > 199000);
  // Values of the size the project writes (µm, °C, s), where rounding is most visible.
  std::uniform_real_distribution<double> u(-1e4, 1e4);
  for (int i = 0; i < 100000; ++i) {
    const double value = u(rng);
    if (read_back(shortest_text(value)) != value) FAIL("value " << value);
  }
}

TEST_CASE("shortest_text: -0 and denormals keep their bits") {
  CHECK(std::signbit(read_back(shortest_text(-0.0))));
  const double tiny = std::numeric_limits<double>::denorm_min() * 12345;
  CHECK(read_back(shortest_text(tiny)) == tiny);
}
