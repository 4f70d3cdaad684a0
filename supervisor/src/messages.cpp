#include "supervisor/messages.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>

#include "common/strict_json.hpp"

namespace alc::supervisor {

namespace {

using Json = nlohmann::json;

// The parsed object, or why the payload is not one.
std::variant<Json, Refusal> object_of(const std::string& payload) {
  Json j;
  try {
    j = common::parse_json_text(payload);
  } catch (const common::JsonTextError& e) {  // not JSON, a number beyond a double, a key twice
    return Refusal{std::string("invalid JSON: ") + e.what()};
  }
  if (!j.is_object()) return Refusal{"not a JSON object"};
  return j;
}

// A finite number at `key` of `j`, or the reason naming `what`.
std::optional<std::string> finite_number(const Json& j, const std::string& key, const std::string& what, double& out) {
  const auto it = j.find(key);
  if (it == j.end()) return what + " is missing";
  if (!it->is_number()) return what + " is not a number: " + it->dump();
  out = it->get<double>();
  if (!std::isfinite(out)) return what + " is not finite";
  return std::nullopt;
}

// The names of `table` that are not in `names`.
std::optional<std::string> unknown_name(const Json& table, const std::vector<std::string>& names) {
  for (const auto& [k, v] : table.items()) {
    bool known = false;
    for (const auto& n : names) known = known || n == k;
    if (!known) return k;
  }
  return std::nullopt;
}

}  // namespace

std::variant<SampleMessage, Refusal> parse_sample(const std::string& payload, const std::vector<std::string>& inputs) {
  auto parsed = object_of(payload);
  if (auto* r = std::get_if<Refusal>(&parsed)) return *r;
  const Json& j = std::get<Json>(parsed);
  SampleMessage m;
  if (auto e = finite_number(j, "time_s", "time_s", m.time_s)) return Refusal{*e};
  const auto table = j.find("inputs");
  if (table == j.end() || !table->is_object()) return Refusal{"inputs is missing or not an object"};
  if (auto u = unknown_name(*table, inputs)) return Refusal{"unknown input '" + *u + "'"};
  m.inputs.resize(static_cast<Eigen::Index>(inputs.size()));
  for (std::size_t i = 0; i < inputs.size(); ++i)
    if (auto e = finite_number(*table, inputs[i], "input " + inputs[i], m.inputs(static_cast<Eigen::Index>(i))))
      return Refusal{*e};
  return m;
}

std::variant<ProbeNowMessage, Refusal> parse_probe_now(const std::string& payload) {
  auto parsed = object_of(payload);
  if (auto* r = std::get_if<Refusal>(&parsed)) return *r;
  const Json& j = std::get<Json>(parsed);
  if (auto u = unknown_name(j, {"reason"})) return Refusal{"unknown key '" + *u + "' (only \"reason\")"};
  const auto reason = j.find("reason");
  if (reason == j.end() || !reason->is_string()) return Refusal{"reason is missing or not a string"};
  ProbeNowMessage m{reason->get<std::string>()};
  if (m.reason.empty() || m.reason.size() > kMaxProbeNowReason)
    return Refusal{"reason has " + std::to_string(m.reason.size()) + " bytes, not 1 to " +
                   std::to_string(kMaxProbeNowReason)};
  return m;
}

std::variant<ProbeResultMessage, Refusal> parse_probe_result(const std::string& payload,
                                                             const std::vector<std::string>& outputs) {
  auto parsed = object_of(payload);
  if (auto* r = std::get_if<Refusal>(&parsed)) return *r;
  const Json& j = std::get<Json>(parsed);
  ProbeResultMessage m;
  const auto id = j.find("id");
  if (id == j.end() || !id->is_number_integer()) return Refusal{"id is missing or not a whole number"};
  // Beyond int64 (up to 2^64 - 1, an unsigned JSON number) no request has that id: named as written, not
  // wrapped to a negative id.
  constexpr auto kLargest = static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max());
  if (id->is_number_unsigned() && id->get<std::uint64_t>() > kLargest)
    return Refusal{"unknown probe id " + id->dump()};
  m.id = id->get<std::int64_t>();
  if (auto e = finite_number(j, "time_s", "time_s", m.time_s)) return Refusal{*e};
  const auto table = j.find("errors");
  if (table == j.end() || !table->is_object()) return Refusal{"errors is missing or not an object"};
  if (auto u = unknown_name(*table, outputs)) return Refusal{"unknown error '" + *u + "'"};
  m.measured = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(outputs.size()),
                                         std::numeric_limits<double>::quiet_NaN());
  bool any = false;
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const auto it = table->find(outputs[i]);
    if (it == table->end() || it->is_null()) continue;
    if (auto e = finite_number(*table, outputs[i], "error " + outputs[i], m.measured(static_cast<Eigen::Index>(i))))
      return Refusal{*e};
    any = true;
  }
  if (!any) return Refusal{"no error was measured"};
  return m;
}

nlohmann::json offsets_json(const nc::AxisOffsets& o) {
  nlohmann::json j = {{"x_mm", o.x_mm}, {"y_mm", o.y_mm}, {"z_mm", o.z_mm}, {"c_deg", o.c_deg}};
  if (o.a_deg) j["a_deg"] = *o.a_deg;
  if (o.b_deg) j["b_deg"] = *o.b_deg;
  return j;
}

nc::AxisOffsets offsets_of(const nlohmann::json& j, int work_offset) {
  nc::AxisOffsets o;
  o.x_mm = j.at("x_mm").get<double>();
  o.y_mm = j.at("y_mm").get<double>();
  o.z_mm = j.at("z_mm").get<double>();
  o.c_deg = j.at("c_deg").get<double>();
  o.a_deg = j.contains("a_deg") ? std::optional<double>(j["a_deg"].get<double>()) : std::nullopt;
  o.b_deg = j.contains("b_deg") ? std::optional<double>(j["b_deg"].get<double>()) : std::nullopt;
  o.work_offset = work_offset;
  return o;
}

}  // namespace alc::supervisor
