#pragma once
// The JSON payloads of the supervisor's MQTT topics (docs/supervisor.md, "Topics"): parsing of what
// comes in (strict: every reason a message is refused is named), nothing else. No I/O.
#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <variant>
#include <vector>

#include "nc_interface/commands.hpp"

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

// PREFIX/probe/now: {"reason": "relevelled after the move"}: someone asks for a probe now, knowing
// what no input shows (the machine moved, relevelled, repaired, after a collision); the reason is a
// string of 1 to kMaxProbeNowReason bytes and the only key.
struct ProbeNowMessage {
  std::string reason;
};
constexpr std::size_t kMaxProbeNowReason = 200;

// A message that is refused: why, in one line.
struct Refusal {
  std::string reason;
};

std::variant<SampleMessage, Refusal> parse_sample(const std::string& payload, const std::vector<std::string>& inputs);
std::variant<ProbeNowMessage, Refusal> parse_probe_now(const std::string& payload);
std::variant<ProbeResultMessage, Refusal> parse_probe_result(const std::string& payload,
                                                             const std::vector<std::string>& outputs);

// Axis offsets as the supervisor writes them ("axis" of PREFIX/offsets and of the journaled probe
// compensation, "held" and "in_force" of the NC events, the saved state's nc_last and nc_in_force):
// {"x_mm", "y_mm", "z_mm", "c_deg"} and "a_deg" / "b_deg" when the chain has them, each value as it is
// (what the NC holds is kept at its resolution where it comes from a delivery, nc::held_after, and
// as read back otherwise). offsets_of reads them back for `work_offset`.
nlohmann::json offsets_json(const nc::AxisOffsets& o);
nc::AxisOffsets offsets_of(const nlohmann::json& j, int work_offset);

}  // namespace alc::supervisor
