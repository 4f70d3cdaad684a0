#include "supervisor/config.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <toml++/toml.h>

#include "common/number_text.hpp"
#include "common/toml_text.hpp"
#include "runtime/toml_option.hpp"

namespace alc::supervisor {

ConfigError::ConfigError(const std::string& file, const std::string& key, const std::string& value,
                         const std::string& reason)
    : std::runtime_error(file + ": key '" + key + "'" + (value.empty() ? "" : ", value " + value) + ": " + reason) {}

ConfigError::ConfigError(const std::string& message) : std::runtime_error(message) {}

namespace {

std::string node_text(const toml::node* node) { return common::toml_value_text(node); }

// One table of the file; remembers the keys read so that unknown ones are reported.
class Section {
 public:
  Section(const toml::table* t, std::string name, std::string file) : t_(t), name_(std::move(name)), file_(std::move(file)) {}
  [[noreturn]] void fail(const std::string& key, const std::string& reason) const {
    throw ConfigError(file_, full(key), node_text(t_ ? t_->get(key) : nullptr), reason);
  }
  std::string full(const std::string& key) const { return name_.empty() ? key : name_ + "." + key; }
  const toml::node* get(const std::string& key) {
    known_.insert(key);
    return t_ ? t_->get(key) : nullptr;
  }
  std::optional<std::string> text(const std::string& key) {
    const toml::node* n = get(key);
    if (!n) return std::nullopt;
    if (!n->is_string() || n->as_string()->get().empty()) fail(key, "not a non-empty string");
    return n->as_string()->get();
  }
  std::string required_text(const std::string& key) {
    auto v = text(key);
    if (!v) fail(key, "missing");
    return *v;
  }
  std::optional<double> number(const std::string& key, double min_exclusive) {
    const toml::node* n = get(key);
    if (!n) return std::nullopt;
    const auto v = n->value<double>();
    if (!v || !std::isfinite(*v)) fail(key, "not a finite number");
    if (!(*v > min_exclusive)) fail(key, "must be > " + common::shortest_text(min_exclusive));
    return *v;
  }
  std::optional<long long> integer(const std::string& key, long long lo, long long hi) {
    const toml::node* n = get(key);
    if (!n) return std::nullopt;
    const auto* i = n->as_integer();
    if (!i || i->get() < lo || i->get() > hi)
      fail(key, "not a whole number from " + std::to_string(lo) + " to " + std::to_string(hi));
    return i->get();
  }
  std::vector<std::string> names(const std::string& key) {
    const toml::node* n = get(key);
    if (!n) fail(key, "missing");
    const toml::array* a = n->as_array();
    if (!a || a->empty()) fail(key, "not a non-empty array of names");
    std::vector<std::string> out;
    std::set<std::string> seen;
    for (const toml::node& e : *a) {
      if (!e.is_string() || e.as_string()->get().empty()) fail(key, "not an array of non-empty strings");
      if (!seen.insert(e.as_string()->get()).second) fail(key, "names " + node_text(&e) + " twice");
      out.push_back(e.as_string()->get());
    }
    return out;
  }
  Section sub(const std::string& key) {
    const toml::node* n = get(key);
    if (n && !n->is_table()) fail(key, "not a table");
    return Section(n ? n->as_table() : nullptr, full(key), file_);
  }
  void no_unknown_keys() const {
    if (!t_) return;
    for (const auto& [k, v] : *t_)
      if (!known_.count(std::string(k.str()))) fail(std::string(k.str()), "unknown key");
  }
  const toml::table* table() const { return t_; }
  const std::string& file() const { return file_; }

 private:
  const toml::table* t_;
  std::string name_;
  std::string file_;
  std::set<std::string> known_;
};

std::filesystem::path relative_to(const std::filesystem::path& file, const std::string& p) {
  const std::filesystem::path path(p);
  return path.is_absolute() ? path : file.parent_path() / path;
}

// [controller]: each key is an option of `alc replay` with its value as that option takes it.
void read_controller(Section s, SupervisorConfig& c) {
  if (!s.table()) {
    c.parameters = runtime::parameters_of({});
    return;
  }
  for (const auto& [k, node] : *s.table()) {
    const std::string key(k.str());
    if (!runtime::find_parameter_option(key)) s.fail(key, "not an option of alc replay (see alc replay --help)");
    std::string text;
    try {
      text = runtime::option_text_of(key, node);
    } catch (const std::invalid_argument& e) {
      s.fail(key, e.what());
    }
    AlcParameters p;
    try {
      runtime::set_parameter(p, key, text);
    } catch (const std::invalid_argument& e) {
      s.fail(key, e.what());
    }
    c.controller_options.emplace_back(key, text);
  }
  try {
    c.parameters = runtime::parameters_of(c.controller_options);
  } catch (const std::invalid_argument& e) {
    throw ConfigError(s.file(), "controller", "", e.what());
  }
}

// [nc] after nc.machine: sink, probe, their connection and the probe cycle.
void read_nc(Section& n, SupervisorConfig& c) {
  NcConfig& nc = c.nc;
  if (auto v = n.text("sink")) {
    if (*v != "none" && *v != "spool" && *v != "linuxcncrsh") n.fail("sink", "not \"none\", \"spool\" or \"linuxcncrsh\"");
    nc.sink = *v;
  }
  if (auto v = n.text("probe")) {
    if (*v != "gateway" && *v != "linuxcnc") n.fail("probe", "not \"gateway\" or \"linuxcnc\"");
    nc.probe = *v;
  }
  if (auto v = n.text("dialect")) {
    const auto d = nc::parse_dialect(*v);
    if (!d) n.fail("dialect", "not \"linuxcnc\", \"fanuc\", \"sinumerik\" or \"heidenhain\"");
    if (*d != nc::Dialect::LinuxCNC && nc.sink == "linuxcncrsh") n.fail("dialect", "sink \"linuxcncrsh\" takes \"linuxcnc\" only");
    nc.dialect = *d;
  }
  if (nc.sink != "none")
    if (const std::string why = nc::missing_base(nc.dialect, c.machine.nc, c.machine.work_offset, c.machine.chain.tilt.name);
        !why.empty())
      n.fail("machine", why + (nc.machine ? "" : "; give nc.machine, a machine file (nc_interface/machine.example.toml)"));
  if (auto v = n.text("spool_dir")) nc.spool_dir = relative_to(c.file, *v);
  if (nc.sink == "spool" && !nc.spool_dir) n.fail("spool_dir", "missing (sink = \"spool\" writes its programs there)");
  if (auto v = n.text("host")) {
    if (*v != "127.0.0.1" && *v != "localhost" && *v != "::1") n.fail("host", "linuxcncrsh is reached on localhost only");
    nc.linuxcncrsh.host = *v;
  }
  if (auto v = n.integer("port", 1, 65535)) nc.linuxcncrsh.port = static_cast<int>(*v);
  if (auto v = n.number("timeout_s", 0.0)) nc.linuxcncrsh.timeout_s = *v;
  if (auto v = n.number("retry_s", 0.0)) nc.retry_s = *v;
  Section p = n.sub("probe_cycle");
  NcProbeCycle& pc = nc.probe_cycle;
  if (auto v = p.text("output")) pc.output = *v;
  if (pc.output != "E_Z0T") p.fail("output", "only \"E_Z0T\" is measured by the NC probe cycle so far");
  if (nc.probe == "linuxcnc" &&
      std::find(c.signals.outputs.begin(), c.signals.outputs.end(), pc.output) == c.signals.outputs.end())
    p.fail("output", "not one of signals.outputs");
  if (const toml::node* v = p.get("point_mm")) {
    const toml::array* a = v->as_array();
    if (!a || a->size() != 3) p.fail("point_mm", "not an array of 3 numbers [x, y, z]");
    for (std::size_t k = 0; k < 3; ++k) {
      const auto x = a->get(k)->value<double>();
      if (!x || !std::isfinite(*x)) p.fail("point_mm", "not an array of 3 finite numbers [x, y, z]");
      pc.point_mm[k] = *x;
    }
  } else if (nc.probe == "linuxcnc") {
    p.fail("point_mm", "missing (probe = \"linuxcnc\" probes there)");
  }
  if (auto v = p.number("clearance_mm", 0.0)) pc.clearance_mm = *v;
  if (auto v = p.number("approach_mm", 0.0)) pc.approach_mm = *v;
  if (auto v = p.number("search_mm", 0.0)) pc.search_mm = *v;
  if (auto v = p.number("feed_mm_min", 0.0)) pc.feed_mm_min = *v;
  if (pc.clearance_mm < pc.approach_mm) p.fail("clearance_mm", "must be at least approach_mm");
  p.no_unknown_keys();
  n.no_unknown_keys();
}

}  // namespace

SupervisorConfig parse_supervisor_config(const std::string& toml_text, const std::filesystem::path& file) {
  const std::string name = file.string();
  toml::table root;
  try {
    root = toml::parse(toml_text, name);
  } catch (const toml::parse_error& e) {
    throw ConfigError(common::toml_syntax_error(name, e));
  }
  SupervisorConfig c;
  c.file = file;
  Section top(&root, "", name);
  c.machine_id = top.required_text("machine_id");

  Section m = top.sub("mqtt");
  if (auto v = m.text("host")) c.mqtt.host = *v;
  if (auto v = m.integer("port", 1, 65535)) c.mqtt.port = static_cast<int>(*v);
  const auto prefix = m.text("prefix");
  c.mqtt.prefix = prefix.value_or("alc/" + c.machine_id);
  if (c.mqtt.prefix.find_first_of("#+") != std::string::npos || c.mqtt.prefix.back() == '/') {
    if (prefix) m.fail("prefix", "must not contain # or + nor end with /");
    top.fail("machine_id", "must not contain # or + nor end with / (without mqtt.prefix it names the topics alc/" +
                               c.machine_id + "/...)");
  }
  c.mqtt.client_id = m.text("client_id").value_or("alc-" + c.machine_id);
  c.mqtt.username = m.text("username");
  if (auto v = m.text("password_file")) c.mqtt.password_file = relative_to(file, *v);
  if (c.mqtt.password_file && !c.mqtt.username) m.fail("password_file", "needs mqtt.username");
  if (auto v = m.text("tls_ca_file")) c.mqtt.tls_ca_file = relative_to(file, *v);
  if (auto v = m.integer("keepalive_s", 5, 3600)) c.mqtt.keepalive_s = static_cast<int>(*v);
  if (auto v = m.integer("max_payload_bytes", 256, 16 * 1024 * 1024))
    c.mqtt.max_payload_bytes = static_cast<std::size_t>(*v);
  m.no_unknown_keys();

  Section s = top.sub("signals");
  c.signals.inputs = s.names("inputs");
  c.signals.outputs = s.names("outputs");
  for (const auto& o : c.signals.outputs)
    if (o.rfind("E_", 0) != 0) s.fail("outputs", "'" + o + "' does not start with E_");
  // An input named like an error (an output among them too) would be an output in every scenario CSV
  // made of the run.
  for (const auto& i : c.signals.inputs)
    if (i.rfind("E_", 0) == 0) s.fail("inputs", "'" + i + "' starts with E_, which names an error (an output)");
  if (auto v = s.number("stale_after_s", 0.0)) c.signals.stale_after_s = *v;
  if (auto v = s.number("probe_timeout_s", 0.0)) c.signals.probe_timeout_s = *v;
  if (auto v = s.number("max_gap_s", 0.0)) c.signals.max_gap_s = *v;
  s.no_unknown_keys();

  Section h = top.sub("history");
  c.history.db = relative_to(file, h.required_text("db"));
  if (auto v = h.number("snapshot_every_h", 0.0)) c.history.snapshot_every_s = *v * 3600.0;
  if (auto v = h.number("keep_days", 0.0)) c.history.keep_s = *v * 86400.0;
  if (auto v = h.text("durability")) {
    if (*v == "process") c.history.durability = storage::Durability::Process;
    else if (*v == "power") c.history.durability = storage::Durability::Power;
    else h.fail("durability", "not \"process\" or \"power\"");
  }
  h.no_unknown_keys();

  read_controller(top.sub("controller"), c);

  Section n = top.sub("nc");
  if (auto v = n.text("machine")) {
    c.nc.machine = relative_to(file, *v);
    try {
      c.machine = nc::read_machine_config(*c.nc.machine);
    } catch (const nc::ConfigError& e) {
      throw ConfigError(name, "nc.machine", "\"" + *v + "\"", e.what());
    }
  }
  c.machine.nc.writer = nc::ProgramWriter::AlcSupervise;  // named in the spooled programs
  read_nc(n, c);

  if (top.table()->contains("status")) {
    Section st = top.sub("status");
    StatusConfig sc;
    // "PORT", ":PORT", "HOST:PORT" (IPv4 or a name) or "[IPV6]:PORT"; the default host is 127.0.0.1.
    const std::string listen = st.required_text("listen");
    std::string host, port;
    if (listen.front() == '[') {
      const auto close = listen.find(']');
      if (close == std::string::npos || close + 1 >= listen.size() || listen[close + 1] != ':')
        st.fail("listen", "not \"[IPV6]:PORT\" (e.g. \"[::1]:8080\")");
      host = listen.substr(1, close - 1);
      port = listen.substr(close + 2);
      if (host.empty() || host.find_first_not_of("0123456789abcdefABCDEF:.") != std::string::npos)
        st.fail("listen", "not an IPv6 address in brackets (e.g. \"[::1]:8080\")");
    } else {
      const auto colon = listen.rfind(':');
      host = colon == std::string::npos ? "" : listen.substr(0, colon);
      port = colon == std::string::npos ? listen : listen.substr(colon + 1);
      if (host.find(':') != std::string::npos)
        st.fail("listen", "an IPv6 address is written in brackets before the port (e.g. \"[::1]:8080\")");
    }
    if (!host.empty()) sc.host = host;
    if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
        std::stoi(port) < 1 || std::stoi(port) > 65535 || sc.host.find_first_of(" /[]") != std::string::npos)
      st.fail("listen", "not \"PORT\", \"HOST:PORT\" or \"[IPV6]:PORT\" with a port from 1 to 65535");
    sc.port = std::stoi(port);
    if (auto v = st.number("window_h", 0.0)) sc.window_s = *v * 3600.0;
    st.no_unknown_keys();
    c.status = sc;
  }

  Section l = top.sub("log");
  c.log.level = l.text("level");
  c.log.file = l.text("file");
  if (c.log.file) c.log.file = relative_to(file, *c.log.file).string();
  l.no_unknown_keys();
  top.no_unknown_keys();
  return c;
}

SupervisorConfig read_supervisor_config(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw ConfigError(file.string(), "(file)", "", "cannot be read");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_supervisor_config(text.str(), file);
}

}  // namespace alc::supervisor
