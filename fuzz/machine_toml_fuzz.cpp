// libFuzzer target: the machine config TOML (nc_interface/machine_config.hpp). Any input either
// gives a config whose limits and NC options are valid, or is refused with ConfigError.
#include <cstddef>
#include <cstdint>
#include <string>

#include "nc_interface/dialects.hpp"
#include "nc_interface/machine_config.hpp"
#include "nc_interface/safety.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  alc::nc::MachineConfig config;
  try {
    config = alc::nc::parse_machine_config(std::string(reinterpret_cast<const char*>(data), size), "fuzz.toml");
  } catch (const alc::nc::ConfigError&) {
    return 0;
  }
  if (!alc::nc::validate(config.limits).empty() || !alc::nc::validate(config.nc).empty()) __builtin_trap();
  return 0;
}
