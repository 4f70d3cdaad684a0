// The supervisor's NC ([nc] sink "spool"/"linuxcncrsh", probe "linuxcnc"): the parts of Supervisor
// that talk to the NC through NcLink. docs/supervisor.md, "The NC", describes the behaviour:
// - after every controller cycle the commands the safety gate let through go to the sink; a failure is
//   recorded (nc_commands.delivered = 0 with the error, a NcDeliveryFailed event) and the NC observer
//   is rolled back to what the NC is known to hold, so it steps again from there at the next cycle
//   (after retry_s of wall-clock time) and the gate judges every step against what the NC holds;
// - what the NC holds is read back at the first contact of a process and after a failure; when it
//   differs from what the supervisor believes, the observer continues from what it holds;
// - for every probe request, the compensation in force (what the NC holds, read back, in the error
//   space) is journaled in the inbox ("nc/compensation") before its result, so a restart learns from
//   the same compensation (restart determinism does not depend on the NC being reachable);
// - probe "linuxcnc": the supervisor runs the probe cycle itself and its result enters as a
//   probe/result message would (journaled, learned from at its own time).
// Nothing here throws: every NC failure is an event.
#include <cmath>
#include <utility>
#include <nlohmann/json.hpp>

#include "common/log.hpp"
#include "nc_interface/jsonl.hpp"
#include "nc_interface/safety.hpp"
#include "runtime/nc_emitter.hpp"
#include "runtime/run.hpp"
#include "storage/history_writer.hpp"
#include "supervisor/inbox.hpp"
#include "supervisor/messages.hpp"
#include "supervisor/nc_link.hpp"
#include "supervisor/supervisor.hpp"

namespace alc::supervisor {

using Json = nlohmann::json;

namespace {

std::shared_ptr<spdlog::logger> logger() { return log::get("supervisor"); }

}  // namespace

void Supervisor::on_nc_cycle() {
  if (!link_ || !link_->delivers()) return;
  const std::vector<nc::NcCommand>& sent = nc_->recorder().to_send();
  std::vector<nc::NcCommand> fresh(sent.begin() + static_cast<std::ptrdiff_t>(std::min(nc_sent_, sent.size())),
                                   sent.end());
  nc_sent_ = sent.size();
  // A probe interval that did not get through goes first (offsets are re-stepped by the observer).
  if (nc_retry_ && !recovering_) fresh.insert(fresh.begin(), *std::exchange(nc_retry_, std::nullopt));
  if (!fresh.empty() && recovering_) {
    nc_held_ = nc_->state().in_force;  // delivered before the restart, as far as is known: sync_nc checks
  } else if (!fresh.empty()) {
    const nc::AxisOffsets believed = nc_held_;
    std::string error = nc_synced_ ? std::string() : sync_nc(false);
    NcDelivery d;
    if (error.empty() && !same_on_nc(nc_held_, believed)) {
      error = "not sent: the NC holds " + offsets_json(nc_held_).dump() + ", not the " + offsets_json(believed).dump() +
              " these commands step from; the next cycle steps from what it holds";
    } else if (error.empty()) {
      // A sink that cannot be read back: what is held and what is handed over, journaled first, so a
      // restart after a kill mid-delivery knows what the NC may hold (settle_nc_after_recovery).
      if (!link_->reads_back()) {
        Json commands = Json::array();
        for (const nc::NcCommand& c : fresh) commands.push_back(nc::to_json_line(c));
        entry_seq_ = inbox_->append("nc/sending", Json{{"held", offsets_json(nc_held_)}, {"commands", commands}}.dump());
      }
      d = link_->deliver(fresh);
      error = d.error;
      for (std::size_t k = 0; k < d.delivered; ++k)
        if (const auto* o = std::get_if<nc::AxisOffsets>(&fresh[k])) nc_held_ = nc::held_after(nc_held_, *o);
    }
    const storage::RunId run = lifecycle_->run();
    if (error.empty()) {
      writer_->record_delivery(run, link_->sink_name(), true,
                               link_->reads_back() ? "taken; read back equal" : "taken");
      if (nc_failing_) {
        nc_failing_ = false;
        event({{"type", "NcDeliveryResumed"}, {"time_s", controller_.state().now_s}, {"reason", "the NC takes offsets again"}});
      }
    } else {
      const std::string message = d.delivered ? std::to_string(d.delivered) + " of " + std::to_string(fresh.size()) +
                                                    " command(s) taken, then: " + error
                                              : error;
      writer_->record_delivery(run, link_->sink_name(), false, message);
      logger()->warn("NC delivery failed, offsets held at what the NC holds: {}", message);
      event({{"type", "NcDeliveryFailed"},
             {"time_s", controller_.state().now_s},
             {"reason", message},
             {"held", offsets_json(nc_held_)}});
      for (std::size_t k = d.delivered; k < fresh.size(); ++k)
        if (std::holds_alternative<nc::ProbeInterval>(fresh[k])) nc_retry_ = fresh[k];
      nc_failing_ = true;
      nc_synced_ = false;  // read it back before the next attempt
      roll_back_nc(nc_held_);
    }
  }
  // What the offsets in force cancel, in the error space (a step toward the target cancels part of it).
  compensation_ = error_space_->compensation(nc_->state().in_force, compensation_);
}

// After the recovery of a restart, with a sink that cannot be read back (spool). The recovery made
// again the commands after the snapshot but could not know which reached the NC: it holds what it held
// at the snapshot, or, when a delivery was journaled after it, what the latest one held plus any of its
// commands. Those commands are handed over again (totals: one that was written already changes nothing,
// one that was not is a step within max_step of what was held), so the NC holds what they make; the
// offsets step on from there. Before, the recovery took every command made again for delivered: a kill
// between the journal and the spool lost a step, its row read 'taken', and the next step was twice
// max_step on the machine.
void Supervisor::settle_nc_after_recovery(const nc::AxisOffsets& at_snapshot) {
  const std::optional<std::string> sending = std::exchange(nc_sending_, std::nullopt);
  if (!link_ || !link_->delivers() || link_->reads_back()) return;  // read back instead (sync_nc)
  nc::AxisOffsets held = at_snapshot;
  std::string how = "held at the snapshot, nothing handed over after it";
  if (sending) {
    const Json j = Json::parse(*sending);
    held = offsets_of(j.at("held"), config_.machine.work_offset);
    std::vector<nc::NcCommand> again;
    for (const Json& line : j.at("commands")) again.push_back(nc::parse_command_json(line.get<std::string>(), "inbox"));
    const NcDelivery d = link_->deliver(again);
    for (std::size_t k = 0; k < d.delivered; ++k)
      if (const auto* o = std::get_if<nc::AxisOffsets>(&again[k])) held = nc::held_after(held, *o);
    if (!d.error.empty())
      throw std::runtime_error("the NC's offsets are not known after the restart: the " + std::to_string(again.size()) +
                               " command(s) being handed to " + link_->sink_name() +
                               " at the stop could not be handed over again (" + d.error +
                               "): not started, as no step would be known to be within max_step of what it holds");
    how = "the " + std::to_string(again.size()) + " command(s) being handed over at the stop, handed over again";
  }
  nc_held_ = held;
  // The rows the recovery made again (after the snapshot) had no delivery: not known to have reached it.
  writer_->record_delivery(lifecycle_->run(), link_->sink_name(), false,
                           "made again at a restart; not known to have reached the NC, which holds " +
                               offsets_json(held).dump() + " (" + how + ")");
  if (!same_on_nc(held, nc_->state().in_force)) {
    logger()->warn("after the restart the NC holds {} ({}), not the offsets in force {}: continuing from it",
                   offsets_json(held).dump(), how, offsets_json(nc_->state().in_force).dump());
    event({{"type", "NcResync"},
           {"time_s", controller_.state().now_s},
           {"reason", "after the restart the NC holds what was handed over last (" + how +
                          "), not the offsets in force; the offsets step from what it holds"},
           {"held", offsets_json(held)},
           {"in_force", offsets_json(nc_->state().in_force)}});
    roll_back_nc(held);
    compensation_ = error_space_->compensation(held, compensation_);
    offsets_changed_ = true;
  }
}

void Supervisor::roll_back_nc(const nc::AxisOffsets& held) {
  runtime::NcCommandObserver::State st = nc_->state();
  st.last = held;
  st.in_force = held;
  st.behind = true;  // every cycle is a moment until the target is reached again
  nc_->restore(st);
}

// Reads back what the NC holds; when it is not what the supervisor believes, the NC observer continues
// from it. Returns the error (empty when read back). settle_rows (at a (re)start, nothing being sent):
// the nc_commands rows still without a delivery (rebuilt by the recovery) get what the read-back says.
std::string Supervisor::sync_nc(bool settle_rows) {
  if (!link_ || !link_->reads_back() || !link_->delivers()) return "";
  nc::AxisOffsets held;
  try {
    held = link_->read_back(config_.machine.work_offset);
  } catch (const nc::SinkError& e) {
    logger()->warn("NC read-back failed: {}", e.what());
    return e.what();
  }
  nc_synced_ = true;
  const nc::AxisOffsets in_force = nc_->state().in_force;
  if (settle_rows)
    writer_->record_delivery(lifecycle_->run(), link_->sink_name(), same_on_nc(held, in_force),
                             same_on_nc(held, in_force)
                                 ? "read back at the start: the NC holds the offsets in force"
                                 : "read back at the start: the NC holds " + offsets_json(held).dump() + ", not these");
  if (!same_on_nc(held, in_force)) {
    logger()->warn("the NC holds {}, not the offsets in force {}: continuing from what it holds",
                   offsets_json(held).dump(), offsets_json(in_force).dump());
    event({{"type", "NcResync"},
           {"time_s", controller_.state().now_s},
           {"reason", "read back: the NC does not hold the offsets in force; the offsets step from what it holds"},
           {"held", offsets_json(held)},
           {"in_force", offsets_json(in_force)}});
    roll_back_nc(held);
    compensation_ = error_space_->compensation(held, compensation_);
    offsets_changed_ = true;
  }
  nc_held_ = held;
  return "";
}

void Supervisor::after_message_nc() {
  if (!link_ || recovering_ || stopped_) return;
  if (outstanding_ && !result_ && journaled_probe_ != outstanding_->id) journal_probe_compensation();
  if (outstanding_ && !result_ && config_.nc.probe == "linuxcnc") run_nc_probe();
}

// The compensation in force for the outstanding probe: what the NC holds, read back (or, when it
// cannot be read, what it is known to hold), in the error space; into the inbox before its result.
void Supervisor::journal_probe_compensation() {
  nc::AxisOffsets held = link_->delivers() ? nc_held_ : nc_->state().in_force;
  std::string source = link_->delivers() ? "known to be held" : "in force";
  if (link_->reads_back()) {
    try {
      held = link_->read_back(config_.machine.work_offset);
      source = "read back";
    } catch (const nc::SinkError& e) {
      source = std::string("known to be held (read-back failed: ") + e.what() + ")";
      event({{"type", "NcReadBackFailed"}, {"id", outstanding_->id}, {"reason", e.what()}});
    }
  }
  const Eigen::VectorXd c = error_space_->compensation(held, compensation_);
  const Json payload = {{"id", outstanding_->id},
                        {"compensation", std::vector<double>(c.data(), c.data() + c.size())},
                        {"axis", offsets_json(held)},
                        {"source", source}};
  entry_seq_ = inbox_->append("nc/compensation", payload.dump());
  apply_probe_compensation(payload.dump());
}

void Supervisor::apply_probe_compensation(const std::string& payload) {
  const Json j = Json::parse(payload);
  const auto id = j.at("id").get<std::int64_t>();
  journaled_probe_ = id;
  if (!outstanding_ || outstanding_->id != id) return;
  const auto c = j.at("compensation").get<std::vector<double>>();
  Eigen::VectorXd v = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(config_.signals.outputs.size()));
  for (std::size_t i = 0; i < c.size() && static_cast<Eigen::Index>(i) < v.size(); ++i)
    v(static_cast<Eigen::Index>(i)) = c[i];
  outstanding_->compensation = v;
}

void Supervisor::run_nc_probe() {
  const NcProbeCycle& p = config_.nc.probe_cycle;
  const std::int64_t id = outstanding_->id;
  double z = 0.0;
  try {
    z = link_->probe_z(config_.machine.work_offset);
  } catch (const nc::SinkError& e) {
    logger()->warn("probe cycle {} on the NC failed: {}", id, e.what());
    event({{"type", "NcProbeFailed"}, {"id", id}, {"time_s", last_received_s_}, {"reason", e.what()},
           {"retry", "at the next sample after retry_s, until probe_timeout_s"}});
    return;
  }
  // The tool tip touches the surface when the commanded Z (plus the offsets in force) plus the tool's
  // error E_Z0T reaches it: nominal - probed = E_Z0T - compensation, the closed-loop measurement.
  const double measured_um = (p.point_mm[2] - z) * 1000.0;
  event({{"type", "NcProbe"}, {"id", id}, {"time_s", last_received_s_}, {"probed_z_mm", z},
         {"nominal_z_mm", p.point_mm[2]}, {"output", p.output}, {"measured", measured_um},
         {"reason", "G38.2 on the NC"}});
  const Json result = {{"id", id}, {"time_s", last_received_s_}, {"errors", {{p.output, measured_um}}}};
  process("probe/result", result.dump(), -1);
}

}  // namespace alc::supervisor
