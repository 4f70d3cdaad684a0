#pragma once
// The controller's parameters as named options with units: one table for `alc replay`'s options
// (--cp 6.5) and a study grid's keys (cp = [6.5, 12]), one strict parser for their values.
//
// Each option also says when it first matters in a run (its Stage): a parameter study runs the sets
// that agree on the earlier stages as one controller and forks it where they first differ
// (docs/study.md). The stages follow the controller (alc/src/controller.cpp): the Post-CP options are
// consulted only once CP ends, the No-Good options only at the first ACL breach after CP.
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "alc/controller.hpp"

namespace alc::runtime {

enum class Stage {
  Start,   // from the first sample (CP length, CP interval, learning options)
  CpEnd,   // from the end of CP (Post-CP interval, ACL, periodic update, refit on probes)
  Breach,  // from the first ACL breach after CP (NG interval, NG measurements, breach confirmation)
};

// What an option takes. set_parameter parses and checks a value by it, and its message says it
// (values_text): the one place where the bound of an option is written.
enum class Domain {
  NonNegative,      // a number >= 0
  Positive,         // a number > 0
  PositiveOrInf,    // a number > 0 or inf
  AtLeastOneOrInf,  // a number >= 1 or inf
  WholeOrInf,       // a whole number >= 0 or inf
  Order,            // a whole number from 1 to 16
  Flag,             // true or false
  Choice,           // one of the option's `choices`
};

struct ParameterOption {
  std::string_view name;     // "cp": --cp on the command line, a key of a study grid
  std::string_view unit;     // "h", "min", "µm", "-"
  Domain domain = Domain::Positive;
  std::string_view help;
  Stage stage = Stage::Start;
  std::string_view field;    // the AlcParameters field it sets, as validate() names it ("cp_duration_s")
  std::string_view choices;  // Domain::Choice: the words it takes, "paper or adaptive"
};

// What an option takes, for messages: "a number > 0 or inf", "true or false", "paper or adaptive".
std::string values_text(const ParameterOption& option);

// Every option, in the order of `alc replay --help`.
const std::vector<ParameterOption>& parameter_options();
const ParameterOption* find_parameter_option(std::string_view name);

// Option texts (name, value) in the order given; an option given twice: the last wins.
using OptionTexts = std::vector<std::pair<std::string, std::string>>;

// Sets option `name` of `p` from `text` (numbers by common::parse_number: decimal, no sign, hex,
// nan; "inf" where the option takes it). Throws std::invalid_argument naming the option and the value.
void set_parameter(AlcParameters& p, std::string_view name, std::string_view text);

// A combination of valid option values that the controller refuses (AlcParameters::validate()).
struct InvalidParameters : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

// The parameters of the defaults with `options` applied, validated (p.validate()). Throws
// std::invalid_argument naming the option and the value, or InvalidParameters naming the violated
// constraint, by the option and the value given where the user gave it ("invalid parameters: cp = 0
// (cp_duration_s = 0): must be positive and finite").
AlcParameters parameters_of(const OptionTexts& options);

}  // namespace alc::runtime
