// Shared by the commands: selection of built-in load cases by name (--case), seeds and the other
// numeric options, all read by the one strict reader of number text (common/number_text.hpp).
#include <stdexcept>

#include "commands.hpp"
#include "common/number_text.hpp"
#include "scenarios/load_cases.hpp"

namespace alc::cli {

std::vector<std::string> load_case_names(const std::string& selector) {
  std::vector<std::string> names;
  if (selector == "all") {
    for (const auto& info : scenarios::load_cases()) names.push_back(info.name);
  } else if (selector == "heldout") {
    for (const auto& info : scenarios::heldout_cases()) names.push_back(info.name);
  } else if (scenarios::find_case(selector)) {
    names.push_back(selector);
  } else {
    throw UsageError("--case: unknown load case '" + selector + "' (see 'alc simulate --list')");
  }
  return names;
}

std::uint64_t parse_seed(const std::string& text, const std::string& option) {
  try {
    return common::parse_whole_number(option, text, 0, UINT64_MAX);
  } catch (const std::invalid_argument&) {
    throw UsageError(option + " must be a whole number from 0 to 18446744073709551615, got '" + text + "'");
  }
}

std::uint64_t whole_option_value(const std::string& name, const std::string& text, std::uint64_t lo, std::uint64_t hi) {
  try {
    return common::parse_whole_number(name, text, lo, hi);
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
}

double number_option_value(const std::string& name, const std::string& text, double lo, double hi, bool allow_inf) {
  double v = 0.0;
  try {
    v = common::parse_number(name, text, allow_inf);
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  if (v < lo || v > hi)
    throw UsageError(name + ": '" + text + "' is not a number from " + common::shortest_text(lo) + " to " +
                     common::shortest_text(hi));
  return v;
}

CLI::Option* add_number_option(CLI::App* cmd, const std::string& name, double& target, const std::string& help,
                               double lo, double hi, bool allow_inf) {
  return cmd
      ->add_option_function<std::string>(
          name,
          [&target, name, lo, hi, allow_inf](const std::string& text) {
            target = number_option_value(name, text, lo, hi, allow_inf);
          },
          help)
      ->type_name(allow_inf ? "NUMBER|inf" : "NUMBER");
}

}  // namespace alc::cli
