#include "supervisor/nc_link.hpp"

#include <Eigen/QR>
#include <cmath>
#include <numbers>

#include "common/log.hpp"
#include "nc_interface/nc_number.hpp"

namespace alc::supervisor {

namespace {

constexpr double kUradPerDeg = std::numbers::pi / 180.0 * 1e6;

std::string text(double v) { return nc::format_nc_number(v); }

}  // namespace

ErrorSpace::ErrorSpace(const kinematics::MachineChain& chain, const std::vector<std::string>& outputs,
                       const std::vector<bool>& cancellable)
    : chain_(chain), cancellable_(cancellable) {
  const auto n = static_cast<Eigen::Index>(outputs.size());
  j_ = Eigen::MatrixXd::Zero(5, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    // Every location error moves the offsets the observer sends (E_B0C's position part too), so
    // every one is a column; only the cancellable ones are reported.
    if (kinematics::location_error_field(outputs[static_cast<std::size_t>(i)]) < 0) continue;
    kinematics::LocationErrors e{};
    kinematics::set_location_error(e, kinematics::location_error_field(outputs[static_cast<std::size_t>(i)]), 1.0);
    const kinematics::Compensation c = kinematics::compensate(chain_, {}, e);
    j_.col(i) << c.offsets.x_um, c.offsets.y_um, c.offsets.z_um, c.offsets.tilt_urad, c.offsets.table_urad;
  }
  pinv_ = Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd>(j_).pseudoInverse();
}

Eigen::VectorXd ErrorSpace::offsets_vector(const nc::AxisOffsets& o) const {
  const double tilt = chain_.tilt.name == 'B' ? o.b_deg.value_or(0.0) : o.a_deg.value_or(0.0);
  Eigen::VectorXd v(5);
  v << o.x_mm * 1000.0, o.y_mm * 1000.0, o.z_mm * 1000.0, tilt * kUradPerDeg, o.c_deg * kUradPerDeg;
  return v;
}

Eigen::VectorXd ErrorSpace::compensation(const nc::AxisOffsets& held, const Eigen::VectorXd& intended) const {
  Eigen::VectorXd p = Eigen::VectorXd::Zero(j_.cols());
  for (Eigen::Index i = 0; i < p.size() && i < intended.size(); ++i)
    if (std::isfinite(intended(i))) p(i) = intended(i);
  // How far along the intended offsets the held ones are (1: all of it, 0: none), then the rest of
  // the held offsets by least norm.
  const Eigen::VectorXd o = offsets_vector(held);
  const Eigen::VectorXd jp = j_ * p;
  const double t = jp.squaredNorm() > 0.0 ? jp.dot(o) / jp.squaredNorm() : 0.0;
  Eigen::VectorXd c = t * p + pinv_ * (o - t * jp);
  for (Eigen::Index i = 0; i < c.size(); ++i)
    if (!cancellable_[static_cast<std::size_t>(i)]) c(i) = 0.0;
  return c;
}

bool same_on_nc(const nc::AxisOffsets& a, const nc::AxisOffsets& b) {
  const auto near = [](double x, double y) { return std::abs(x - y) <= 0.5e-4 + 1e-12; };
  return near(a.x_mm, b.x_mm) && near(a.y_mm, b.y_mm) && near(a.z_mm, b.z_mm) &&
         near(a.a_deg.value_or(0.0), b.a_deg.value_or(0.0)) && near(a.b_deg.value_or(0.0), b.b_deg.value_or(0.0)) &&
         near(a.c_deg, b.c_deg);
}

NcLink::NcLink(const SupervisorConfig& config) : config_(config) {
  const NcConfig& c = config.nc;
  if (c.uses_linuxcncrsh()) rsh_ = std::make_unique<nc::LinuxcncrshSink>(c.linuxcncrsh, config.machine.nc);
  if (c.sink == "linuxcncrsh") sink_ = rsh_.get();
  if (c.sink == "spool") {
    spool_ = std::make_unique<nc::SpoolSink>(*c.spool_dir, c.dialect, config.machine.nc);
    sink_ = spool_.get();
  }
}

NcLink::~NcLink() = default;

std::string NcLink::sink_name() const { return sink_ ? sink_->name() : std::string(); }

nc::LinuxcncrshClient& NcLink::client() {
  if (!rsh_) throw nc::SinkError("no linuxcncrsh connection is configured");
  nc::LinuxcncrshClient& c = rsh_->client();
  if (!c.connected()) c.connect();
  return c;
}

void NcLink::check_may_try() const {
  if (!failed_at_) return;
  const double since = std::chrono::duration<double>(std::chrono::steady_clock::now() - *failed_at_).count();
  if (since < config_.nc.retry_s)
    throw nc::SinkError("not tried: the NC failed " + text(since) + " s ago, next attempt after retry_s = " +
                        text(config_.nc.retry_s) + " s (" + last_error_ + ")");
}

void NcLink::failed(const std::string& error) {
  // A fresh session next time (the linuxcncrsh sink closes its own on an error).
  if (rsh_) rsh_->client().close();
  failed_at_ = std::chrono::steady_clock::now();
  last_error_ = error;
}

NcDelivery NcLink::deliver(const std::vector<nc::NcCommand>& commands) {
  NcDelivery d;
  if (!sink_) return d;
  try {
    check_may_try();
  } catch (const nc::SinkError& e) {
    d.error = e.what();
    return d;
  }
  for (const nc::NcCommand& c : commands) {
    try {
      sink_->deliver(c);
    } catch (const std::exception& e) {
      d.error = nc::delivery_error(*sink_, e);
      failed(d.error);
      return d;
    }
    ++d.delivered;
  }
  failed_at_.reset();
  return d;
}

nc::AxisOffsets NcLink::read_back(int work_offset) {
  check_may_try();
  try {
    const std::array<double, 6> v = client().work_offset_values(work_offset);
    const nc::BaseOffset& b = config_.machine.nc.base[static_cast<std::size_t>(work_offset - 1)];
    nc::AxisOffsets o;
    o.work_offset = work_offset;
    o.x_mm = v[0] - b.x_mm;
    o.y_mm = v[1] - b.y_mm;
    o.z_mm = v[2] - b.z_mm;
    if (config_.machine.chain.tilt.name == 'B') {
      o.a_deg.reset();
      o.b_deg = v[4] - b.b_deg;
    } else {
      o.a_deg = v[3] - b.a_deg;
    }
    o.c_deg = v[5] - b.c_deg;
    failed_at_.reset();
    return o;
  } catch (const std::exception& e) {
    failed(e.what());
    throw nc::SinkError(e.what());
  }
}

double NcLink::probe_z(int work_offset) {
  check_may_try();
  const NcProbeCycle& p = config_.nc.probe_cycle;
  const double x = p.point_mm[0], y = p.point_mm[1], z = p.point_mm[2];
  try {
    nc::LinuxcncrshClient& c = client();
    c.mdi({"G21 G90 " + nc::work_offset_name(work_offset), "G0 Z" + text(z + p.clearance_mm),
           "G0 X" + text(x) + " Y" + text(y), "G0 Z" + text(z + p.approach_mm)});
    c.request("get error");  // takes an older message off the error channel
    c.mdi({"G38.2 Z" + text(z - p.search_mm) + " F" + text(p.feed_mm_min)});
    // A move that ends without contact is an error of the NC (and leaves #5070 = 0).
    const std::string error = c.request("get error");
    const std::vector<double> r = c.parameters({5070, 5061, 5062, 5063}, "the probe result #5070 #5061-#5063");
    c.mdi({"G0 Z" + text(z + p.clearance_mm)});
    if (error != "ERROR OK" || r[0] != 1.0 || !(r[3] > z - p.search_mm + 1e-6))
      throw nc::SinkError("G38.2 made no contact between Z" + text(z + p.approach_mm) + " and Z" +
                          text(z - p.search_mm) + " (#5070 = " + text(r[0]) + ", #5063 = " + text(r[3]) +
                          ", NC: '" + error + "')");
    failed_at_.reset();
    log::get("supervisor")->info("probe cycle: contact at Z {} (nominal {})", r[3], z);
    return r[3];
  } catch (const std::exception& e) {
    failed(e.what());
    throw nc::SinkError(e.what());
  }
}

}  // namespace alc::supervisor
