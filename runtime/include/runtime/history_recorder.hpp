#pragma once
// Records what the driver saw and decided into the SQLite history (storage/): every sample, the
// prediction with the axis offsets that cancel it, every probe with the phase it was taken in,
// phase and interval changes, and every identification.
#include <string>
#include <vector>

#include "alc/kinematics.hpp"
#include "runtime/driver.hpp"
#include "storage/history_writer.hpp"

namespace alc::runtime {

class HistoryRecorder : public Observer {
 public:
  // `record_offsets`: store with every prediction the axis offsets of the driver's machine
  // (Cycle::compensation(); NaN where it did not converge), in the order of offset_names(chain).
  HistoryRecorder(storage::HistoryWriter& writer, storage::RunId run, bool record_offsets);
  void on_cycle(const Cycle& cycle) override;

  // "X_um", "Y_um", "Z_um", "<tilt>_urad", "<table>_urad": the offset channels of a chain.
  static std::vector<std::string> offset_names(const kinematics::MachineChain& chain);
  // The RunRecord::offset_names of a run with these outputs: offset_names(chain) when some output is
  // one of the seven C-axis location errors (then offsets can be derived), else none.
  static std::vector<std::string> offset_names(const kinematics::MachineChain& chain,
                                               const std::vector<std::string>& output_names);

 private:
  void record_events(const Cycle& cycle);
  storage::HistoryWriter& writer_;
  storage::RunId run_;
  bool record_offsets_;
};

}  // namespace alc::runtime
