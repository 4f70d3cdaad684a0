// libFuzzer target: the supervisor's config TOML (supervisor/config.hpp). Any input either gives a
// config whose controller parameters are valid and whose outputs are named, or is refused with
// ConfigError. The file is taken to lie in a directory that does not exist; inputs that could name a
// path outside it (a '/', or a \u escape that could spell one) are skipped: nc.machine is read while
// parsing, and a device such as /dev/zero would never end.
#include <cstddef>
#include <cstdint>
#include <string>

#include "supervisor/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  if (text.find('/') != std::string::npos || text.find("\\u") != std::string::npos ||
      text.find("\\U") != std::string::npos)
    return 0;
  alc::supervisor::SupervisorConfig config;
  try {
    config = alc::supervisor::parse_supervisor_config(text, "/nonexistent-alc-fuzz/supervisor.toml");
  } catch (const alc::supervisor::ConfigError&) {
    return 0;
  }
  if (!config.parameters.validate().empty() || config.signals.outputs.empty())
    __builtin_trap();
  return 0;
}
