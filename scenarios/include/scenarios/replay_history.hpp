#pragma once
// Replay with history: records what the replay saw and decided into the SQLite history
// (storage/), saves resumable snapshots, and encodes the replay state bit for bit.
#include <cstdint>
#include <string>

#include <optional>
#include <vector>

#include "alc/kinematics.hpp"
#include "scenarios/replay.hpp"
#include "storage/history_writer.hpp"

namespace alc::scenarios {

// Exact binary form of a replay state (controller, model, baseline, evaluation so far).
// Format "alc.replay-state/2"; decode throws std::runtime_error on a truncated or foreign payload.
inline constexpr const char* kReplayStateFormat = "alc.replay-state/2";
std::string encode_replay_state(const ReplayState& state);
ReplayState decode_replay_state(const std::string& payload);

// Writes every sample, prediction, probe, phase change, interval change and identification of a
// replay into `writer` under `run`, and a snapshot every `snapshot_every_s` of scenario time: after
// the first row at or past the run's first sample + snapshot_every_s, then after the first row at or
// past the previous snapshot + snapshot_every_s. A recorder of a resumed run counts from the run's
// first sample too, so past that point it saves a snapshot after its first row (docs/storage.md).
class HistoryRecorder : public ReplayObserver {
 public:
  HistoryRecorder(storage::HistoryWriter& writer, storage::RunId run, const Controller& controller,
                  double snapshot_every_s = 24 * 3600.0);
  void on_sample(std::size_t row, double time_s, const Eigen::VectorXd& inputs, const ControllerOutput& out) override;
  // Stores the probe with the phase it was taken in, not the one its handling led to: a breaching
  // Post-CP probe is a Post-CP probe (its PhaseChange event to NG follows in phase_changes).
  void on_probe(std::size_t row, const ProbeMeasurement& probe, const ControllerOutput& out) override;
  // Also record, with every prediction, the axis offsets that cancel it (kinematics::compensate at
  // the reference pose, tilt = table = 0), in the order of offset_names(chain). Only when some output
  // is one of the seven C-axis errors; the run's RunRecord::offset_names must be offset_names(chain).
  void record_offsets(const kinematics::MachineChain& chain, std::vector<std::string> output_names);
  // "X_um", "Y_um", "Z_um", "<tilt>_urad", "C_urad": the offset channels of record_offsets().
  static std::vector<std::string> offset_names(const kinematics::MachineChain& chain);
  // The RunRecord::offset_names of a run with these outputs: offset_names(chain) when record_offsets()
  // will record offsets (some output is a C-axis error), else none.
  static std::vector<std::string> offset_names(const kinematics::MachineChain& chain,
                                               const std::vector<std::string>& output_names);
  // Saves a snapshot when one is due.
  void on_row_done(const ReplaySession& session) override;
  // Stores the session's state as a snapshot (commits everything before it).
  void save_snapshot(const ReplaySession& session);

 private:
  void record_events(const ControllerOutput& out, double time_s);
  storage::HistoryWriter& writer_;
  storage::RunId run_;
  const Controller& controller_;
  double snapshot_every_s_;
  double next_snapshot_s_ = -kInf;
  std::optional<kinematics::MachineChain> chain_;   // set by record_offsets()
  std::vector<std::string> output_names_;
};

}  // namespace alc::scenarios
