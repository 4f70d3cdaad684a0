// The option table (runtime/parameter_options.cpp): every option's domain is what set_parameter
// enforces, value by value, and what its message says. One table, one check per domain.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "common/number_text.hpp"
#include "runtime/parameter_options.hpp"

namespace rt = alc::runtime;

namespace {

// The message set_parameter gives for `text`, or "" if it takes it.
std::string refusal(const rt::ParameterOption& o, const std::string& text) {
  alc::AlcParameters p;
  try {
    rt::set_parameter(p, o.name, text);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("parameter options: each option takes exactly the values of its domain, and says so") {
  std::size_t checked = 0;
  for (const rt::ParameterOption& o : rt::parameter_options()) {
    INFO("option " << o.name);
    const std::string says = rt::values_text(o);
    REQUIRE_FALSE(says.empty());
    const auto refused = [&](const std::string& text) {
      INFO("value '" << text << "'");
      CHECK(refusal(o, text) == std::string(o.name) + ": '" + text + "' is not " + says);
    };
    const auto taken = [&](const std::string& text) {
      INFO("value '" << text << "'");
      CHECK(refusal(o, text).empty());
    };
    const bool duration = o.unit == "h" || o.unit == "min";  // at least 1 s: 0.02 min is 1.2 s
    // Not numbers (or not the NC's numbers): refused in the option's own words, whatever its domain.
    refused("-1"), refused("0x10"), refused("nan"), refused("");
    switch (o.domain) {
      case rt::Domain::NonNegative:
        taken("0"), taken("2.5"), refused("inf");
        break;
      case rt::Domain::Positive:
        taken(duration ? "0.02" : "0.001"), taken("7"), refused("0"), refused("inf");
        break;
      case rt::Domain::PositiveOrInf:
        taken(duration ? "0.02" : "0.001"), taken("inf"), refused("0");
        break;
      case rt::Domain::AtLeastOneOrInf:
        taken("1"), taken("inf"), refused("0.999");
        break;
      case rt::Domain::WholeOrInf:
        taken("0"), taken("12"), taken("inf"), refused("6.5");
        break;
      case rt::Domain::Order:
        taken("1"), taken("16"), refused("0"), refused("17"), refused("2.5"), refused("inf");
        break;
      case rt::Domain::Flag:
        taken("true"), taken("false"), refused("yes"), refused("1");
        CHECK(says == "true or false");
        break;
      case rt::Domain::Choice: {
        // "a or b": both words are taken, anything else refused.
        const auto cut = says.find(" or ");
        REQUIRE(cut != std::string::npos);
        taken(says.substr(0, cut)), taken(says.substr(cut + 4)), refused("other");
        break;
      }
    }
    // A length of time takes at least 1 s (1e-20 h had left a sample's time as it was: no probe after CP).
    if (duration && o.domain != rt::Domain::NonNegative) {
      const double unit_s = o.unit == "h" ? 3600.0 : 60.0;
      CHECK(refusal(o, "1e-20") == std::string(o.name) + ": '1e-20' " + std::string(o.unit) +
                                       " is shorter than 1 s, no time the controller can tell from 0");
      taken(alc::common::shortest_text(1.0 / unit_s * 1.000001));
      CHECK_FALSE(refusal(o, alc::common::shortest_text(0.999 / unit_s)).empty());
    }
    ++checked;
  }
  CHECK(checked == rt::parameter_options().size());
  CHECK(checked >= 27);
  // The messages as users see them (the README and the CLI tests quote these).
  CHECK(refusal(*rt::find_parameter_option("ng-meas"), "6.5") == "ng-meas: '6.5' is not a whole number >= 0 or inf");
  CHECK(refusal(*rt::find_parameter_option("max-order"), "17") == "max-order: '17' is not a whole number from 1 to 16");
  CHECK(refusal(*rt::find_parameter_option("method"), "ls") == "method: 'ls' is not fixed-poles or output-error");
  CHECK(refusal(*rt::find_parameter_option("cp"), "inf") == "cp: 'inf' is not a number > 0");  // was ">= 0"
  CHECK(refusal(*rt::find_parameter_option("cp"), "1e999") == "cp: '1e999' is out of the range of a double (about 2.2e-308 to 1.8e308)");
}
