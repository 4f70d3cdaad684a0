// libFuzzer target: a study grid in TOML (study::parse_grid). Any input either gives a grid or is
// refused with GridError (file:line:column, key, value).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "study/grid.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    alc::study::parse_grid(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.toml");
  } catch (const alc::study::GridError&) {
  }
  return 0;
}
