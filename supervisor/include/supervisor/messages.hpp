#pragma once
// The JSON payloads of the supervisor's MQTT topics (docs/supervisor.md, "Topics"): parsing of what
// comes in (strict: every reason a message is refused is named), nothing else. No I/O.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <variant>
#include <vector>

namespace alc::supervisor {

// PREFIX/sample: {"time_s": 86400.0, "inputs": {"T_ENV": 21.3, ...}}, every input present and finite.
struct SampleMessage {
  double time_s = 0.0;
  Eigen::VectorXd inputs;  // in the order of the configured input names
};

// PREFIX/probe/result: {"id": 17, "time_s": 23460.0, "errors": {"E_X0C": 1.2, ...}}; an error that
// was not measured is absent or null (NaN here).
struct ProbeResultMessage {
  std::int64_t id = 0;
  double time_s = 0.0;
  Eigen::VectorXd measured;  // in the order of the configured output names, NaN = not measured
};

// A message that is refused: why, in one line.
struct Refusal {
  std::string reason;
};

std::variant<SampleMessage, Refusal> parse_sample(const std::string& payload, const std::vector<std::string>& inputs);
std::variant<ProbeResultMessage, Refusal> parse_probe_result(const std::string& payload,
                                                             const std::vector<std::string>& outputs);

}  // namespace alc::supervisor
