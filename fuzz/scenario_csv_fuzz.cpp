// libFuzzer target: the scenario CSV reader (scenarios/scenario_csv.hpp). Any input either parses
// or is refused with ScenarioCsvError; what the writer writes of a parsed scenario reads back and
// writes again to the same text.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "scenarios/scenario_csv.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  alc::scenarios::Scenario s;
  try {
    s = alc::scenarios::parse_scenario_csv(in, "fuzz.csv");
  } catch (const alc::scenarios::ScenarioCsvError&) {
    return 0;
  }
  std::ostringstream out;
  try {
    alc::scenarios::write_scenario_csv(out, s);
  } catch (const std::invalid_argument&) {
    return 0;  // the writer refuses what it cannot write back (documented)
  }
  std::istringstream back(out.str());
  std::ostringstream again;
  alc::scenarios::write_scenario_csv(again, alc::scenarios::parse_scenario_csv(back, "written.csv"));
  if (again.str() != out.str()) __builtin_trap();
  return 0;
}
