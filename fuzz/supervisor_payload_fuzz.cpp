// libFuzzer target: the supervisor's MQTT payloads (supervisor/messages.hpp). The first byte picks
// the topic (odd: PREFIX/probe/result; of the even, 2 mod 4: PREFIX/probe/now, else PREFIX/sample),
// the rest is the payload. A probe/now accepted has a reason of 1 to 200 bytes and, asked of a started
// controller, makes a probe due at once with an event that quotes it. Any payload is
// either refused with a reason, or gives a message of the configured size whose values are finite
// (a probe result: NaN where not measured, at least one measured). What is accepted then goes to a
// controller as the supervisor hands it over: bad data never throws there (accepted = false or a
// plausibility event), and an accepted cycle predicts finite values.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <variant>
#include <vector>

#include "alc/controller.hpp"
#include "supervisor/messages.hpp"

namespace {

const std::vector<std::string> kInputs = {"T_ENV", "T_WS", "n_C", "CF_on"};
const std::vector<std::string> kOutputs = {"E_X0C", "E_Z0T", "E_A0C", "E_C0C"};

void check_prediction(const alc::ControllerOutput& out) {
  if (!out.accepted) {
    if (out.reason.empty()) __builtin_trap();
    return;
  }
  if (out.prediction.size() != static_cast<Eigen::Index>(kOutputs.size()) || !out.prediction.allFinite())
    __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const bool probe = (data[0] & 1) != 0;
  const std::string payload(reinterpret_cast<const char*>(data) + 1, size - 1);
  alc::Controller controller(kInputs, kOutputs, alc::AlcParameters{});
  if (!probe && (data[0] & 3) == 2) {
    const auto parsed = alc::supervisor::parse_probe_now(payload);
    if (const auto* r = std::get_if<alc::supervisor::Refusal>(&parsed)) {
      if (r->reason.empty()) __builtin_trap();
      return 0;
    }
    const std::string& reason = std::get<alc::supervisor::ProbeNowMessage>(parsed).reason;
    if (reason.empty() || reason.size() > alc::supervisor::kMaxProbeNowReason) __builtin_trap();
    Eigen::VectorXd inputs(static_cast<Eigen::Index>(kInputs.size()));
    inputs << 21.0, 21.5, 800.0, 1.0;
    check_prediction(controller.on_sample(0.0, inputs));
    const alc::ControllerOutput out = controller.request_probe(0.0, reason);
    check_prediction(out);
    // The first sample made the first CP probe due: asked again, nothing changes and nothing is said.
    if (!out.accepted || !out.events.empty() || out.next_probe_due_s != 0.0) __builtin_trap();
    // Once it is taken the next is 5 min away (CP): asked at 1 min, it is due then, the reason quoted.
    if (!controller.on_probe({0.0, Eigen::VectorXd::Zero(static_cast<Eigen::Index>(kOutputs.size())), {}}).accepted)
      __builtin_trap();
    const alc::ControllerOutput later = controller.request_probe(60.0, reason);
    if (!later.accepted || later.events.size() != 1 || later.events[0].reason != "probe requested: " + reason ||
        later.next_probe_due_s != 60.0)
      __builtin_trap();
    return 0;
  }
  if (!probe) {
    const auto parsed = alc::supervisor::parse_sample(payload, kInputs);
    if (const auto* r = std::get_if<alc::supervisor::Refusal>(&parsed)) {
      if (r->reason.empty()) __builtin_trap();
      return 0;
    }
    const auto& m = std::get<alc::supervisor::SampleMessage>(parsed);
    if (m.inputs.size() != static_cast<Eigen::Index>(kInputs.size()) || !m.inputs.allFinite() || !std::isfinite(m.time_s))
      __builtin_trap();
    check_prediction(controller.on_sample(m.time_s, m.inputs));
    return 0;
  }
  const auto parsed = alc::supervisor::parse_probe_result(payload, kOutputs);
  if (const auto* r = std::get_if<alc::supervisor::Refusal>(&parsed)) {
    if (r->reason.empty()) __builtin_trap();
    return 0;
  }
  const auto& m = std::get<alc::supervisor::ProbeResultMessage>(parsed);
  if (m.measured.size() != static_cast<Eigen::Index>(kOutputs.size()) || !std::isfinite(m.time_s)) __builtin_trap();
  bool any = false;
  for (Eigen::Index i = 0; i < m.measured.size(); ++i) {
    if (std::isinf(m.measured(i))) __builtin_trap();
    any = any || !std::isnan(m.measured(i));
  }
  if (!any) __builtin_trap();
  Eigen::VectorXd inputs(static_cast<Eigen::Index>(kInputs.size()));
  inputs << 21.0, 21.5, 800.0, 1.0;
  const double start = std::isfinite(m.time_s - 60.0) ? m.time_s - 60.0 : m.time_s;
  check_prediction(controller.on_sample(start, inputs));
  const alc::ControllerOutput out = controller.on_probe({m.time_s, m.measured, {}});
  check_prediction(out);
  // Every error set aside is named with its reading, beyond its limit.
  for (const alc::ControllerEvent& e : out.events)
    if (e.type == alc::ControllerEvent::Type::Implausible && (e.output.empty() || !(std::abs(e.value) > e.limit)))
      __builtin_trap();
  return 0;
}
