#include "nc_interface/machine_config.hpp"
#include <cmath>

#include <fstream>
#include <set>
#include <sstream>
#include <toml++/toml.h>

#include "common/toml_text.hpp"

#include "common/byte_codec.hpp"
#include "common/input_file.hpp"
#include "nc_interface/nc_number.hpp"

namespace alc::nc {
namespace {

std::string node_text(const toml::node* node) { return common::toml_value_text(node); }

// Reads one table; remembers which keys were read so that unknown keys can be reported.
class Table {
 public:
  Table(const toml::table* table, std::string path, const std::string& file) : t_(table), path_(std::move(path)), file_(file) {}

  [[noreturn]] void fail(const std::string& key, const std::string& reason) const {
    throw ConfigError(file_, full(key), node_text(t_ ? t_->get(key) : nullptr), reason);
  }
  // The same, naming the key's line in the file (a key that is there).
  [[noreturn]] void fail_at_line(const std::string& key, const std::string& reason) const {
    const toml::node* n = t_ ? t_->get(key) : nullptr;
    throw ConfigError(file_, full(key), node_text(n), reason, n ? static_cast<int>(n->source().begin.line) : 0);
  }
  std::string full(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  // The line of the table in the file ([nc.base.G54]); 0 when not known (an implicit table).
  int line() const { return t_ ? static_cast<int>(t_->source().begin.line) : 0; }
  bool has(const std::string& key) const { return t_ && t_->contains(key); }

  const toml::node* get(const std::string& key) {
    known_.insert(key);
    return t_ ? t_->get(key) : nullptr;
  }

  void number(const std::string& key, double& out) {
    const toml::node* n = get(key);
    if (!n) return;
    if (const auto v = n->value<double>()) out = *v;
    else fail(key, "not a number");
    if (!std::isfinite(out)) fail(key, "not a finite number");
  }
  void integer(const std::string& key, int& out) {
    const toml::node* n = get(key);
    if (!n) return;
    const auto v = n->as_integer();
    if (!v || v->get() < -1000000 || v->get() > 1000000) fail(key, "not an integer in ±1e6");
    out = static_cast<int>(v->get());
  }
  std::optional<std::string> text(const std::string& key) {
    const toml::node* n = get(key);
    if (!n) return std::nullopt;
    if (!n->is_string()) fail(key, "not a string");
    return n->as_string()->get();
  }
  void vector(const std::string& key, Eigen::Vector3d& out) {
    const toml::node* n = get(key);
    if (!n) return;
    const toml::array* a = n->as_array();
    if (!a || a->size() != 3) fail(key, "not an array of three numbers");
    for (std::size_t i = 0; i < 3; ++i) {
      const auto v = a->get(i)->value<double>();
      if (!v || !std::isfinite(*v)) fail(key, "not an array of three finite numbers");
      out(static_cast<Eigen::Index>(i)) = *v;
    }
  }
  Table sub(const std::string& key) {
    const toml::node* n = get(key);
    if (n && !n->is_table()) fail(key, "not a table");
    return Table(n ? n->as_table() : nullptr, full(key), file_);
  }
  void no_unknown_keys() const {
    if (!t_) return;
    for (const auto& [k, v] : *t_)
      if (!known_.count(std::string(k.str()))) fail(std::string(k.str()), "unknown key");
  }
  bool present() const { return t_ != nullptr; }
  std::vector<std::string> keys() const {
    std::vector<std::string> out;
    if (t_) for (const auto& [k, v] : *t_) out.emplace_back(k.str());
    return out;
  }

 private:
  const toml::table* t_;
  std::string path_;
  const std::string& file_;
  std::set<std::string> known_;
};

void read_axis_limits(Table t, AxisLimits& l) {
  const std::pair<const char*, double*> keys[] = {{"x_mm", &l.x_mm}, {"y_mm", &l.y_mm}, {"z_mm", &l.z_mm},
                                                  {"a_deg", &l.a_deg}, {"b_deg", &l.b_deg}, {"c_deg", &l.c_deg}};
  for (const auto& [key, value] : keys) {
    t.number(key, *value);
    if (!(*value > 0.0)) t.fail(key, "must be > 0");
  }
  t.no_unknown_keys();
}

void read_kinematics(Table t, kinematics::MachineChain& chain) {
  if (const auto c = t.text("chain")) {
    if (*c == "A-C") chain = kinematics::MachineChain::ac_trunnion();
    else if (*c == "B-C") chain = kinematics::MachineChain::bc_trunnion();
    else t.fail("chain", "must be \"A-C\" or \"B-C\"");
  }
  t.vector("tilt_direction", chain.tilt.direction);
  t.vector("tilt_pivot_mm", chain.tilt.pivot_mm);
  t.vector("table_direction", chain.table.direction);
  t.vector("table_pivot_mm", chain.table.pivot_mm);
  t.vector("workpiece_point_mm", chain.workpiece_point_mm);
  t.no_unknown_keys();
  // The key the violation is about (kinematics::validate words it by axis), "chain" for the rest.
  if (const std::string e = kinematics::validate(chain); !e.empty()) {
    const std::pair<const char*, const char*> keys[] = {{"tilt axis direction", "tilt_direction"},
                                                        {"tilt axis pivot", "tilt_pivot_mm"},
                                                        {"table axis direction", "table_direction"},
                                                        {"table axis pivot", "table_pivot_mm"},
                                                        {"tilt and table axis directions", "table_direction"},
                                                        {"workpiece point", "workpiece_point_mm"}};
    const char* key = "chain";
    for (const auto& [start, k] : keys)
      if (e.rfind(start, 0) == 0) key = k;
    t.fail(key, e);
  }
}

void read_nc(Table t, MachineConfig& config) {
  if (const auto wo = t.text("work_offset")) {
    const auto index = parse_work_offset(*wo);
    if (!index) t.fail("work_offset", "must be one of G54 … G59");
    config.work_offset = *index;
  }
  DialectOptions& o = config.nc;
  t.integer("linuxcnc_interval_parameter", o.linuxcnc_interval_parameter);
  t.integer("fanuc_interval_variable", o.fanuc_interval_variable);
  t.integer("fanuc_program_number", o.fanuc_program_number);
  t.integer("sinumerik_interval_r", o.sinumerik_interval_r);
  t.integer("heidenhain_interval_qr", o.heidenhain_interval_qr);
  if (const auto name = t.text("heidenhain_program_name")) o.heidenhain_program_name = *name;
  Table base = t.sub("base");
  for (const std::string& key : base.keys()) {
    const auto index = parse_work_offset(key);
    if (!index) base.fail(key, "must be one of G54 … G59");
    BaseOffset& b = o.base[static_cast<std::size_t>(*index - 1)];
    Table bt = base.sub(key);
    b.given = true;
    b.line = bt.line();
    const std::pair<const char*, double*> axes[] = {{"x_mm", &b.x_mm},  {"y_mm", &b.y_mm},  {"z_mm", &b.z_mm},
                                                    {"a_deg", &b.a_deg}, {"b_deg", &b.b_deg}, {"c_deg", &b.c_deg}};
    for (std::size_t i = 0; i < 6; ++i) {
      bt.number(axes[i].first, *axes[i].second);
      b.axes[i] = bt.has(axes[i].first);
      // Named by its key, line and value (validate() below knows the work offset only, and named the
      // whole [nc.base] table as the value).
      if (b.axes[i] && !(std::abs(*axes[i].second) <= kMaxBase))
        bt.fail_at_line(axes[i].first, "a base offset must be finite and within ±1e5 (with the compensation it must "
                                       "print within ±1e6)");
    }
    bt.no_unknown_keys();
    // A base for the tilt axis the chain does not have is never written: G10 L2 writes the chain's
    // tilt axis from a base of 0 instead (an A-C chain with only b_deg set A to the compensation).
    const char tilt = config.chain.tilt.name;
    const char* other = tilt == 'A' ? "b_deg" : "a_deg";
    if (bt.has(other))
      bt.fail_at_line(other, std::string("the machine's chain (kinematics.chain) is ") + (tilt == 'A' ? "A-C" : "B-C") +
                                 ", which has no " + (tilt == 'A' ? "B" : "A") + " axis: give the tilt axis's base as " +
                                 (tilt == 'A' ? "a_deg" : "b_deg") + ", or set the chain (kinematics.chain = \"" +
                                 (tilt == 'A' ? "B-C" : "A-C") + "\")");
  }
  t.no_unknown_keys();
  if (const std::string e = validate(o); !e.empty()) {
    const std::string key = e.substr(0, e.find(' '));
    t.fail(key, e);
  }
}

void read_limits(Table t, SafetyLimits& l) {
  read_axis_limits(t.sub("max_offset"), l.max_offset);
  read_axis_limits(t.sub("max_step"), l.max_step);
  if (const auto a = t.text("on_step_violation")) {
    if (*a == "refuse") l.on_step_violation = StepAction::Refuse;
    else if (*a == "split") l.on_step_violation = StepAction::Split;
    else t.fail("on_step_violation", "must be \"refuse\" or \"split\"");
  }
  t.integer("max_split_steps", l.max_split_steps);
  t.number("step_period_s", l.step_period_s);
  if (!(l.step_period_s > 0.0)) t.fail("step_period_s", "must be > 0 (seconds of machine time per max_step)");
  t.no_unknown_keys();
  if (const std::string e = validate(l); !e.empty()) {
    // "max_offset of axis X …" -> key max_offset.x_…; name the table and let the message say the axis.
    t.fail(e.substr(0, e.find(' ')), e);
  }
}

}  // namespace

ConfigError::ConfigError(std::string file_, std::string key_, std::string value_, const std::string& reason_, int line_,
                         const std::string& message)
    : std::runtime_error(!message.empty() ? message
                         : key_.empty()   ? file_ + ": " + reason_  // the file itself, not a key
                                      : file_ + ": key '" + key_ + "'" +
                                            (line_ > 0 ? " (line " + std::to_string(line_) + ")" : std::string()) +
                                            ": " + reason_ + (value_.empty() ? std::string() : ": value '" + value_ + "'")),
      file(std::move(file_)), key(std::move(key_)), value(std::move(value_)), reason(reason_), line(line_) {}

MachineConfig parse_machine_config(const std::string& toml_text, const std::string& source_name) {
  toml::table root;
  try {
    root = toml::parse(toml_text, source_name);
  } catch (const toml::parse_error& e) {
    throw ConfigError(source_name, "", "", std::string(e.description()), static_cast<int>(e.source().begin.line),
                      common::toml_syntax_error(source_name, e));
  }
  MachineConfig config;
  Table top(&root, "", source_name);
  read_kinematics(top.sub("kinematics"), config.chain);
  read_nc(top.sub("nc"), config);
  read_limits(top.sub("limits"), config.limits);
  top.no_unknown_keys();
  return config;
}

MachineConfig read_machine_config(const std::filesystem::path& path) {
  if (const std::string problem = io::input_file_problem(path); !problem.empty())
    throw ConfigError(path.string(), "", "", problem);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path.string(), "", "", "cannot open the file");
  std::ostringstream text;
  text << in.rdbuf();
  MachineConfig config = parse_machine_config(text.str(), path.string());
  config.content_hash = common::checksum64_hex(text.str());
  return config;
}

}  // namespace alc::nc
