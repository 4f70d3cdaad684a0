// Selection of built-in load cases by name, shared by the commands that take --case.
#include "commands.hpp"
#include "scenarios/load_cases.hpp"

namespace alc::cli {

std::vector<std::string> load_case_names(const std::string& selector) {
  std::vector<std::string> names;
  if (selector == "all") {
    for (const auto& info : scenarios::load_cases()) names.push_back(info.name);
  } else if (scenarios::find_case(selector)) {
    names.push_back(selector);
  } else {
    throw UsageError("--case: unknown load case '" + selector + "' (see 'alc simulate --list')");
  }
  return names;
}

}  // namespace alc::cli
