#include "nc_interface/jsonl.hpp"

#include <cmath>
#include <istream>
#include <nlohmann/json.hpp>
#include <ostream>
#include <set>

#include "common/strict_json.hpp"
#include "common/utf8.hpp"
#include "nc_interface/dialects.hpp"

namespace alc::nc {
namespace {

using nlohmann::json;

// A long value quoted in a message: cut between two UTF-8 characters (common::shortened), its bad bytes
// and control characters shown as \xNN, so the message stays one line of text.
std::string shorten(const std::string& text) { return common::shortened(common::escaped_utf8(text, true), 80); }

class LineReader {
 public:
  LineReader(const json& object, const std::string& source, std::size_t line)
      : object_(object), source_(source), line_(line) {}

  [[noreturn]] void fail(const std::string& field, const std::string& reason) const {
    const auto it = object_.find(field);
    throw JsonlError(source_, line_, field, it == object_.end() ? std::string() : it->dump(), reason);
  }

  std::optional<double> number(const std::string& field, bool required, bool null_allowed = false) {
    seen_.insert(field);
    const auto it = object_.find(field);
    if (it == object_.end()) {
      if (required) throw JsonlError(source_, line_, field, "", "missing field");
      return std::nullopt;
    }
    if (it->is_null() && null_allowed) return std::nullopt;
    if (!it->is_number()) fail(field, "not a number");
    const double v = it->get<double>();
    if (!std::isfinite(v)) fail(field, "not a finite number");
    return v;
  }

  std::string text(const std::string& field, const std::string& fallback) {
    seen_.insert(field);
    const auto it = object_.find(field);
    if (it == object_.end()) return fallback;
    if (!it->is_string()) fail(field, "not a string");
    return it->get<std::string>();
  }

  void no_unknown_fields() const {
    for (const auto& item : object_.items())
      if (!seen_.count(item.key())) fail(item.key(), "unknown field");
  }

 private:
  const json& object_;
  const std::string& source_;
  std::size_t line_;
  std::set<std::string> seen_{"type"};
};

}  // namespace

JsonlError::JsonlError(std::string source_, std::size_t line_, std::string field_, std::string value_,
                       const std::string& reason_)
    : std::runtime_error(source_ + ":" + std::to_string(line_) + ": " + reason_ +
                         (field_.empty() ? std::string() : " (field '" + field_ + "')") +
                         (value_.empty() ? std::string() : ": value '" + shorten(value_) + "'")),
      source(std::move(source_)), line(line_), field(std::move(field_)), value(shorten(std::move(value_))),
      reason(reason_) {}

NcCommand parse_command_json(const std::string& line_text, const std::string& source, std::size_t line,
                             int default_work_offset) {
  json object;
  try {
    object = common::parse_json_text(line_text);
  } catch (const common::JsonTextError& e) {  // not JSON, a number beyond a double (1e400), a key twice
    if (!e.key.empty()) throw JsonlError(source, line, e.key, "", "duplicate field");
    throw JsonlError(source, line, "", line_text, std::string("not JSON: ") + e.what());
  }
  if (!object.is_object()) throw JsonlError(source, line, "", line_text, "not a JSON object");
  const auto type_it = object.find("type");
  if (type_it == object.end()) throw JsonlError(source, line, "type", "", "missing field");
  if (!type_it->is_string()) throw JsonlError(source, line, "type", type_it->dump(), "not a string");
  const std::string type = type_it->get<std::string>();
  LineReader r(object, source, line);
  NcCommand command;
  if (type == "axis_offsets") {
    AxisOffsets o;
    o.x_mm = *r.number("x_mm", true);
    o.y_mm = *r.number("y_mm", true);
    o.z_mm = *r.number("z_mm", true);
    o.a_deg = r.number("a_deg", false);
    o.b_deg = r.number("b_deg", false);
    o.c_deg = *r.number("c_deg", true);
    if (o.a_deg.has_value() == o.b_deg.has_value())
      r.fail(o.a_deg ? "b_deg" : "a_deg", "exactly one of a_deg and b_deg is required");
    const std::string wo = r.text("work_offset", work_offset_name(default_work_offset));
    const auto index = parse_work_offset(wo);
    if (!index) r.fail("work_offset", "must be one of G54 … G59");
    o.work_offset = *index;
    o.non_compensable_um_per_m = r.number("non_compensable_um_per_m", false);
    o.time_s = r.number("time_s", false);
    command = o;
  } else if (type == "probe_interval") {
    ProbeInterval p;
    p.minutes = r.number("minutes", true, true);
    p.time_s = r.number("time_s", false);
    command = p;
  } else {
    throw JsonlError(source, line, "type", type_it->dump(), "unknown command type (axis_offsets, probe_interval)");
  }
  r.no_unknown_fields();
  if (const std::string e = validate(command); !e.empty()) {
    const std::string field = e.substr(0, e.find(' '));
    throw JsonlError(source, line, object.contains(field) ? field : "",
                     object.contains(field) ? object[field].dump() : line_text, e);
  }
  return command;
}

std::vector<NcCommand> read_commands_jsonl(std::istream& in, const std::string& source, int default_work_offset,
                                           std::vector<std::size_t>* lines) {
  std::vector<NcCommand> out;
  std::string text;
  for (std::size_t line = 1; std::getline(in, text); ++line) {
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (text.find_first_not_of(" \t") == std::string::npos) continue;
    out.push_back(parse_command_json(text, source, line, default_work_offset));
    if (lines) lines->push_back(line);
  }
  return out;
}

std::string to_json_line(const NcCommand& command) {
  nlohmann::ordered_json j;  // "type" first, fields in the documented order
  if (const auto* o = std::get_if<AxisOffsets>(&command)) {
    j["type"] = "axis_offsets";
    j["x_mm"] = o->x_mm;
    j["y_mm"] = o->y_mm;
    j["z_mm"] = o->z_mm;
    if (o->a_deg) j["a_deg"] = *o->a_deg;
    if (o->b_deg) j["b_deg"] = *o->b_deg;
    j["c_deg"] = o->c_deg;
    j["work_offset"] = work_offset_name(o->work_offset);
    if (o->non_compensable_um_per_m) j["non_compensable_um_per_m"] = *o->non_compensable_um_per_m;
    if (o->time_s) j["time_s"] = *o->time_s;
  } else {
    const auto& p = std::get<ProbeInterval>(command);
    j["type"] = "probe_interval";
    if (p.minutes) j["minutes"] = *p.minutes;
    else j["minutes"] = nullptr;
    if (p.time_s) j["time_s"] = *p.time_s;
  }
  return j.dump();
}

void write_commands_jsonl(std::ostream& out, const std::vector<NcCommand>& commands) {
  for (const NcCommand& c : commands) out << to_json_line(c) << "\n";
}

}  // namespace alc::nc
