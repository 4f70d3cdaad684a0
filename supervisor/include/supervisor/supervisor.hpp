#pragma once
// The supervisor's core, event-driven and without network I/O: messages of its topics come in
// (on_message), what it publishes goes out through a Bus. It drives the same controller, driver and
// observers as a replay (runtime/): the history recorder, the run lifecycle (snapshots, resume) and
// the NC observer with its safety gate. docs/supervisor.md describes the behaviour; in short:
// - a sample is accepted (journaled in the inbox, then acted on) or rejected with an event;
// - when a sample reaches the due time, a probe request goes out and the following samples are held
//   (stored in the inbox, not yet given to the controller) until the result arrives: the samples up
//   to the probe's time_s, then the probe, then the rest are processed, so a late result is learned
//   from at its own time and the decisions depend only on the order of the samples; offsets do not
//   change during a probe cycle (the probe measures with one compensation, the one added back);
// - a result that does not come within probe_timeout_s of machine time is given up and reported.
#include <array>
#include <deque>
#include <nlohmann/json.hpp>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "alc/controller.hpp"
#include "nc_interface/commands.hpp"
#include "runtime/driver.hpp"
#include "supervisor/config.hpp"
#include "supervisor/inbox.hpp"
#include "supervisor/messages.hpp"

namespace alc::runtime {
class HistoryRecorder;
class NcCommandObserver;
class RunLifecycle;
}  // namespace alc::runtime
namespace alc::storage {
class HistoryWriter;
}

namespace alc::supervisor {

// The source of a supervisor's run in the history: "supervisor " + machine_id ("supervisor dmu-1").
inline constexpr const char* kRunSourcePrefix = "supervisor ";
inline std::string run_source(const std::string& machine_id) { return kRunSourcePrefix + machine_id; }
inline bool is_run_source(const std::string& source) { return source.rfind(kRunSourcePrefix, 0) == 0; }

// The topics the supervisor reads, below the prefix: the service subscribes to these, on_message
// takes these and rejects any other. A topic with `if_refused` is optional: a broker that refuses its
// subscription costs a warning saying that; a refused required one (nullptr) stops the start.
struct InboundTopic {
  const char* name;
  const char* if_refused;
};
inline constexpr std::array<InboundTopic, 3> kInboundTopics{
    {{"sample", nullptr}, {"probe/result", nullptr}, {"probe/now", "probes cannot be asked for by hand"}}};

class Inbox;
class NcLink;
class ErrorSpace;

class Bus {
 public:
  virtual ~Bus() = default;
  // `topic` below the prefix: "offsets", "probe/request", "state", "event".
  virtual void publish(const std::string& topic, const std::string& payload, bool retained) = 0;
};

struct SupervisorCounts {
  std::int64_t received = 0;       // samples accepted (fed or held)
  std::int64_t rejected = 0;       // messages rejected
  std::int64_t requests = 0;       // probe requests issued
  std::int64_t timeouts = 0;       // probe requests given up
};

class Supervisor {
 public:
  // Opens the history (resuming the run of this machine if one is unfinished; a run begun with
  // another controller configuration is refused with runtime::ResumeRefused) and its inbox, and
  // processes the inbox entries after the latest snapshot again.
  Supervisor(const SupervisorConfig& config, Bus& bus, std::string software_version);
  ~Supervisor();
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // A message of PREFIX/<topic> (one of kInboundTopics) received at wall-clock time wall_s [s].
  void on_message(const std::string& topic, const std::string& payload, double wall_s);
  // Wall-clock time passes: stale detection.
  void on_wall_clock(double wall_s);
  // After (re)connecting: the state (online), the offsets in force and an outstanding request.
  void announce();
  // The retained state message.
  std::string state_json(bool online) const;
  // Clean stop: a snapshot when nothing is held, the run Stopped (resumable), the history closed.
  void stop();

  const SupervisorCounts& counts() const { return counts_; }
  bool stale() const { return stale_; }
  const Controller& controller() const { return controller_; }
  std::size_t held() const { return held_.size(); }
  const Inbox& inbox() const { return *inbox_; }

 private:
  class Tap;
  struct Outstanding {
    std::int64_t id = 0;
    double due_s = 0.0;
    double trigger_s = 0.0;   // time of the sample that reached the due time: a result is not before it
    double asked_s = 0.0;     // the latest sample received when the request went out: the timeout counts from it
    Eigen::VectorXd compensation;  // in force when it was asked for: what the probe measures with
  };
  void process(const std::string& topic, const std::string& payload, std::int64_t seq_if_recovering);
  void accept_sample(const SampleMessage& m, const std::string& payload, std::int64_t seq_if_recovering);
  void reject(const std::string& topic, const std::string& reason);
  void drain();
  void feed(const SampleMessage& m);
  void apply_result();
  void request_probe(double trigger_s);
  // Retention at a snapshot: the history's input samples and predictions older than keep_days.
  void prune_history(double now_s);
  void publish_request();
  void publish_offsets(double time_s);
  void event(nlohmann::json e);
  void publish(const std::string& topic, const std::string& payload, bool retained);
  // Nothing waits: a snapshot may be taken and the inbox pruned up to next_seq_.
  bool idle() const { return !outstanding_ && held_.empty() && !result_ && !jump_ && !asked_; }
  std::string extras_json() const;
  void restore_extras(const std::string& json, double snapshot_s);  // snapshot_s: the snapshot's time
  void begin_or_resume();
  // The NC (supervisor_nc.cpp): deliver what the gate let through in this cycle, roll back to what the
  // NC is known to hold on a failure; read back and journal the compensation in force for a probe;
  // run the probe cycle on LinuxCNC.
  void on_nc_cycle();
  void roll_back_nc(const nc::AxisOffsets& held);
  std::string sync_nc(bool settle_rows);
  void settle_nc_after_recovery(const nc::AxisOffsets& at_snapshot);
  void after_message_nc();
  void journal_probe_compensation();
  void run_nc_probe();
  void apply_probe_compensation(const std::string& payload);

  const SupervisorConfig& config_;
  Bus& bus_;
  std::string software_version_;
  Controller controller_;
  runtime::Driver driver_;
  std::unique_ptr<storage::HistoryWriter> writer_;
  std::unique_ptr<Inbox> inbox_;
  std::unique_ptr<runtime::RunLifecycle> lifecycle_;
  std::unique_ptr<runtime::HistoryRecorder> recorder_;
  std::unique_ptr<runtime::NcCommandObserver> nc_;
  std::unique_ptr<Tap> tap_;
  std::vector<bool> cancellable_;          // per output: an axis offset cancels it
  Eigen::VectorXd compensation_;           // per output: the compensation in force
  Eigen::VectorXd prediction_;             // latest prediction
  bool offsets_changed_ = false;
  double last_offsets_s_ = -kInf;          // [s] machine time of the last offsets message
  std::optional<Outstanding> outstanding_;
  std::optional<ProbeResultMessage> result_;
  std::deque<SampleMessage> held_;
  bool after_timeout_ = false;  // feeding the samples held for a probe that timed out (drain)
  double last_received_s_ = -kInf;         // [s] latest accepted sample (fed or held)
  // A sample more than signals.max_gap_s ahead of the latest, with its payload and its inbox entry
  // (kind "sample/jump", journaled when it comes: a restart holds it again): accepted when the next
  // sample confirms the jump, set aside when it does not.
  struct Jump {
    SampleMessage sample;
    std::string payload;
    std::int64_t seq;
  };
  std::optional<Jump> jump_;
  // The reason of a probe/now (journaled) waiting for the next sample fed without a probe outstanding
  // (after its result or timeout), where it is made due.
  std::optional<std::string> asked_;
  std::int64_t next_id_ = 1;
  std::int64_t next_seq_ = 0;              // inbox entry after the last one processed
  std::int64_t entry_seq_ = 0;             // inbox entry being processed
  std::int64_t snapshots_ = 0;             // snapshots saved by this process
  double pruned_before_s_ = -kInf;         // [s] the history holds no sample before this (pruned)
  bool recovering_ = false;
  bool stale_ = false;
  double last_sample_wall_s_ = 0.0;
  bool stopped_ = false;
  SupervisorCounts counts_;
  std::unique_ptr<NcLink> link_;           // [nc] sink "spool"/"linuxcncrsh" or probe "linuxcnc"
  std::unique_ptr<ErrorSpace> error_space_;
  nc::AxisOffsets nc_held_;                // what the NC is known to hold (delivered or read back)
  std::size_t nc_sent_ = 0;                // entries of the NC observer's to_send() handed to the sink
  bool nc_synced_ = false;                 // nc_held_ was read back from the NC in this process
  bool nc_failing_ = false;                // the last delivery failed
  std::optional<nc::NcCommand> nc_retry_;  // a probe interval not delivered yet (offsets re-step instead)
  std::int64_t journaled_probe_ = 0;       // id of the probe whose compensation is in the inbox
  // A sink that cannot be read back (spool): the latest "nc/sending" entry of the inbox met in the
  // recovery (what was held and the commands handed to the sink, journaled before each delivery).
  std::optional<std::string> nc_sending_;
};

}  // namespace alc::supervisor
