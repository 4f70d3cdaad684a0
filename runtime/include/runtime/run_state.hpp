#pragma once
// The bounded, exact binary form of a run's state for snapshots (docs/storage.md, docs/runtime.md).
//
// A snapshot holds what cannot be recomputed, bounded in size whatever the run's length: the
// controller's plain values, its model and predictor state, the probes of the learning window, and
// the replay's baseline. It does NOT hold the input samples: on restore, the samples the controller
// keeps (ControllerState::history, rows history_first_index .. samples-1 of the run) come back from
// where they were stored (the history's input_samples). Format "alc.run-state" version 8 (3 to 7 are read too), in the
// little-endian byte format of common/byte_codec.hpp, ending with an FNV-1a 64 checksum of all bytes
// before it; decode throws std::runtime_error on a damaged, truncated or foreign payload.
#include <cstdint>
#include <filesystem>
#include <string>

#include "alc/controller.hpp"
#include "alc/static_regression.hpp"
#include "storage/records.hpp"

namespace alc::runtime {

inline constexpr const char* kRunStateFormat = "alc.run-state";
// 9: the guard's level; 8: the first check judging the model; 7: the drift bound; 6: the schedule's kappa
// evidence; 5: the gain guard; 4 (first guard) and 3 are read too.
inline constexpr std::uint32_t kRunStateVersion = 9;

struct RunState {
  std::int64_t next_index = 0;        // source index to continue from
  ControllerState controller;         // history rows empty after decode (restore_history())
  bool baseline_fitted = false;       // the replay's static baseline (Evaluation)
  StaticRegression baseline;
  double identification_s = 0.0;      // [s] wall time (not part of decisions)
  double total_s = 0.0;               // [s]
};

std::string encode_run_state(const RunState& state);
RunState decode_run_state(const std::string& payload);

// Empty if `snapshot` can be resumed from (format kRunStateFormat, a payload that decodes: its
// checksum holds), else why not. The storage::SnapshotCheck of resume and `alc db check`.
std::string run_state_problem(const storage::ControllerSnapshot& snapshot);

// The number of input samples the controller of a decoded state needs back, oldest first: the last
// `history_rows(state)` samples the run accepted.
std::int64_t history_rows(const ControllerState& state);
// Puts those samples back (time_s and inputs, oldest first); throws std::runtime_error when their
// number or width does not match the state.
void restore_history(ControllerState& state, std::vector<double> time_s, InputMatrix inputs);

// Decodes the payload of `snapshot` of `run` in the history `db` and puts back the input samples its
// controller keeps from the run's stored input samples before the snapshot's next_sample_index
// (`inputs` values each). Throws std::runtime_error naming the database when the stored samples do
// not match the state.
RunState load_run_state(const std::filesystem::path& db, storage::RunId run, const storage::ControllerSnapshot& snapshot,
                        std::size_t inputs);

}  // namespace alc::runtime
