#include "scenarios/scenario.hpp"

#include <cstdio>

#include "common/byte_codec.hpp"

namespace alc::scenarios {

std::string content_hash(const Scenario& s) {
  common::ByteWriter w;
  w.strings(s.input_names);
  w.strings(s.output_names);
  w.f64_vector(s.time_s);
  w.matrix(s.inputs);
  w.matrix(s.outputs);
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(common::checksum64(w.take())));
  return hex;
}

}  // namespace alc::scenarios
