#include "scenarios/scenario.hpp"

#include "common/byte_codec.hpp"

namespace alc::scenarios {

std::string content_hash(const Scenario& s) {
  common::ByteWriter w;
  w.strings(s.input_names);
  w.strings(s.output_names);
  w.f64_vector(s.time_s);
  w.matrix(s.inputs);
  w.matrix(s.outputs);
  return common::checksum64_hex(w.take());
}

}  // namespace alc::scenarios
