// Selection of built-in load cases by name, shared by the commands that take --case.
#include <charconv>
#include <system_error>

#include "commands.hpp"
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

std::uint64_t parse_seed(const std::string& text) {
  std::uint64_t value = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || text.front() < '0' || text.front() > '9' || ec != std::errc() || ptr != end)
    throw UsageError("--seed must be a whole number from 0 to 18446744073709551615, got '" + text + "'");
  return value;
}

}  // namespace alc::cli
