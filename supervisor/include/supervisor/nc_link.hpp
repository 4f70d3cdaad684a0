#pragma once
// The supervisor's NC ([nc] in the config; docs/supervisor.md, "The NC"): where the offsets go after
// the safety gate (sink "spool" or "linuxcncrsh"), what the NC holds (read back over linuxcncrsh), and
// the probe cycle it runs itself on LinuxCNC (probe "linuxcnc": G38.2 over linuxcncrsh MDI). Every
// failure is a value or an nc::SinkError for the caller to record; nothing here ends the supervisor.
#include <Eigen/Core>
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "alc/kinematics.hpp"
#include "nc_interface/commands.hpp"
#include "nc_interface/transports.hpp"
#include "supervisor/config.hpp"

namespace alc::supervisor {

// The compensation in force in the error space of the outputs, from the axis offsets an NC holds.
// J maps the location errors among the outputs to the offsets that cancel them at the reference pose
// (kinematics::compensate of a unit error: X Y Z in µm, the rotary axes in µrad). The offsets sent
// were J·intended; of what the NC holds, `held`, compensation() takes the part along them, t =
// (J·intended)·held / |J·intended|², and the rest by least norm: t·intended + J⁺·(held − t·J·intended).
// So it is `intended` when the NC holds what was sent (to the NC resolution), 0 when it holds zero
// offsets, t·intended when it holds a fraction t of them, and what other offsets (an operator's
// change) cancel otherwise. Outputs no axis cancels (E_B0C on an A-C table, non-location outputs)
// are reported 0, as the supervisor's compensation always has them.
class ErrorSpace {
 public:
  ErrorSpace(const kinematics::MachineChain& chain, const std::vector<std::string>& outputs,
             const std::vector<bool>& cancellable);
  Eigen::VectorXd compensation(const nc::AxisOffsets& held, const Eigen::VectorXd& intended) const;

 private:
  Eigen::VectorXd offsets_vector(const nc::AxisOffsets& o) const;  // µm, µm, µm, µrad (tilt), µrad (table)
  kinematics::MachineChain chain_;
  std::vector<bool> cancellable_;
  Eigen::MatrixXd j_;     // 5 × outputs
  Eigen::MatrixXd pinv_;  // outputs × 5
};

// Whether two offsets are the same on the NC (every axis within half its resolution, 0.00005).
bool same_on_nc(const nc::AxisOffsets& a, const nc::AxisOffsets& b);

struct NcDelivery {
  std::size_t delivered = 0;  // commands the sink took, in order
  std::string error;          // why the next one was not taken; empty when all were
};

class NcLink {
 public:
  explicit NcLink(const SupervisorConfig& config);
  ~NcLink();
  NcLink(const NcLink&) = delete;
  NcLink& operator=(const NcLink&) = delete;

  // Whether offsets go to a sink (sink "spool" or "linuxcncrsh"), and its name for nc_commands.sink.
  bool delivers() const { return sink_ != nullptr; }
  std::string sink_name() const;
  // Whether what the NC holds can be read back (linuxcncrsh).
  bool reads_back() const { return rsh_ != nullptr; }

  // Delivers `commands` in order (each read back and compared by the linuxcncrsh sink). Within
  // retry_s of wall-clock time after a failure nothing is tried and the error says so.
  NcDelivery deliver(const std::vector<nc::NcCommand>& commands);
  // The compensation offsets the NC holds on `work_offset`: its stored value minus the configured
  // base, on the chain's axes. Throws nc::SinkError (also within retry_s after a failure).
  nc::AxisOffsets read_back(int work_offset);
  // Runs the configured probe cycle on `work_offset`; returns the probed Z [mm] in its work
  // coordinates (#5063). Throws nc::SinkError: no contact (#5070 = 0), an NC error, unreachable.
  double probe_z(int work_offset);

  const std::string& last_error() const { return last_error_; }

 private:
  void check_may_try() const;
  void failed(const std::string& error);
  nc::LinuxcncrshClient& client();

  const SupervisorConfig& config_;
  std::unique_ptr<nc::LinuxcncrshSink> rsh_;   // linuxcncrsh: the sink and its session
  std::unique_ptr<nc::SpoolSink> spool_;
  nc::Sink* sink_ = nullptr;                   // the one offsets go to, if any
  std::optional<std::chrono::steady_clock::time_point> failed_at_;
  std::string last_error_;
};

}  // namespace alc::supervisor
