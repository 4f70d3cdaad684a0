#include "runtime/run.hpp"

#include <cmath>
#include <tuple>

#include "common/log.hpp"
#include "common/number_text.hpp"
#include "runtime/run_state.hpp"
#include "storage/history_reader.hpp"
#include "storage/storage_error.hpp"

namespace alc::runtime {

namespace {

nlohmann::json number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

}  // namespace

nlohmann::json canonical_parameters(const AlcParameters& p, std::string_view schedule) {
  const IdentificationOptions& i = p.identification;
  nlohmann::json j = {{"schedule", std::string(schedule)},
          {"cp_duration_s", number(p.cp_duration_s)},
          {"cp_interval_s", number(p.cp_interval_s)},
          {"post_cp_interval_s", number(p.post_cp_interval_s)},
          {"ng_interval_s", number(p.ng_interval_s)},
          {"ng_measurements", number(p.ng_measurements)},
          {"update_interval_s", number(p.update_interval_s)},
          {"refit_on_probe", p.refit_on_probe},
          {"confirm_breach", p.confirm_breach},
          {"structure_refresh", number(p.structure_refresh)},
          {"acl_linear_um", number(p.acl_linear_um)},
          {"acl_angular_um_per_m", number(p.acl_angular_um_per_m)},
          {"learning_window_s", number(p.learning_window_s)},
          {"learning_since_s", number(p.learning_since_s)},
          {"identification",
           {{"method", i.method == IdentificationMethod::FixedPoles ? "fixed-poles" : "output-error"},
            {"base_step_s", number(i.base_step_s)},
            {"max_order", i.max_order},
            {"tau_min_s", number(i.tau_min_s)},
            {"tau_max_s", number(i.tau_max_s)},
            {"pole_grid_size", i.pole_grid_size},
            {"criterion", static_cast<int>(i.criterion)},
            {"select_inputs", i.select_inputs},
            {"max_inputs", i.max_inputs},
            {"ridge", number(i.ridge)},
            {"robust_loss", static_cast<int>(i.robust_loss)},
            {"robust_scale_lin", number(i.robust_scale_lin)},
            {"robust_scale_ang", number(i.robust_scale_ang)},
            {"forgetting_half_life_s", number(i.forgetting_half_life_s)},
            {"min_measurements", i.min_measurements},
            {"output_limit_factor", number(i.output_limit_factor)},
            {"max_iterations", i.max_iterations}}}};
  // Added with the adaptive schedule and the guard: present only where they differ from what a run
  // before them did, so the identity of those runs (and their --resume) is unchanged.
  if (p.schedule_kind == AlcParameters::Schedule::Adaptive)
    j["adaptive"] = {{"uncertainty_fraction", number(p.uncertainty_fraction)},
                     {"min_interval_s", number(p.min_interval_s)},
                     {"max_interval_s", number(p.max_interval_s)}};
  if (p.guard) j["guard"] = true;
  const AlcParameters defaults;
  // Added with the move check's option: present only where it can change the run and is not its default.
  if (p.move_fraction_read() && p.move_fraction != defaults.move_fraction)
    j["move_fraction"] = number(p.move_fraction);
  // Added with the plausibility limits: present only where a limit differs from its default.
  const std::pair<const char*, double AlcParameters::*> limits[] = {
      {"linear_um", &AlcParameters::plausible_linear_um},
      {"angular_um_per_m", &AlcParameters::plausible_angular_um_per_m},
      {"temperature_C", &AlcParameters::plausible_temperature_C},
      {"speed_rpm", &AlcParameters::plausible_speed_rpm},
      {"other", &AlcParameters::plausible_other}};
  for (const auto& [key, field] : limits)
    if (p.*field != defaults.*field) j["plausible"][key] = number(p.*field);
  return j;
}

RunLifecycle::RunLifecycle(storage::HistoryWriter& writer, const storage::RunRecord& record, double snapshot_every_s)
    : writer_(writer), snapshot_every_s_(snapshot_every_s) {
  run_ = writer_.begin_run(record);
  log::get("runtime")->info("run {} of '{}' begun", run_, record.source);
}

bool unfinished(const storage::RunRecord& r) {
  return r.status == storage::RunStatus::Running || r.status == storage::RunStatus::Stopped;
}

std::string scenario_hash_of(const std::string& config_json) {
  const auto j = nlohmann::json::parse(config_json, nullptr, false);
  return j.is_object() && j.contains("scenario_hash") && j["scenario_hash"].is_string()
             ? j["scenario_hash"].get<std::string>()
             : std::string();
}

std::optional<storage::RunRecord> latest_unfinished_run(const std::vector<storage::RunRecord>& runs,
                                                        const std::string& source) {
  std::optional<storage::RunRecord> found;
  for (const auto& r : runs)
    if (r.source == source && unfinished(r)) found = r;
  return found;
}

std::optional<storage::RunRecord> run_to_resume(const std::vector<storage::RunRecord>& runs, const std::string& source,
                                                const std::string& config_json) {
  // By content: a replay's identity holds its scenario's hash, so a run with the same identity was
  // recorded from the same data whatever path named it. The same source first, then the latest.
  const bool by_content = !scenario_hash_of(config_json).empty();
  std::optional<storage::RunRecord> same_source, same_content;
  for (const auto& r : runs) {
    if (!unfinished(r) || r.config_json != config_json) continue;
    if (r.source == source) same_source = r;
    else if (by_content) same_content = r;
  }
  if (same_source) return same_source;
  if (same_content) return same_content;
  // None of this identity: the latest unfinished run of the same source, which the caller refuses
  // naming what differs (other data, parameters).
  return latest_unfinished_run(runs, source);
}

std::string unfinished_runs_text(const storage::HistoryReader& history, const std::vector<storage::RunRecord>& runs) {
  std::string text;
  for (const auto& r : runs) {
    if (!unfinished(r)) continue;
    text += (text.empty() ? "" : "; ") + std::string("run ") + std::to_string(r.run_id) + " of '" + r.source + "' (" +
            (r.status == storage::RunStatus::Stopped ? "stopped" : "running: killed or still running");
    const auto span = history.time_span(r.run_id);
    if (const auto snap = history.latest_snapshot(r.run_id); !snap)
      text += ", no snapshot";
    else if (snap->time_s == storage::kSnapshotBeforeStart_s || span.empty)
      text += ", its latest snapshot before the first sample";
    else
      text += ", its latest snapshot at " + common::shortest_text(std::round((snap->time_s - span.first_s) / 36.0) / 100.0) +
              " h from its first sample";
    const std::string hash = scenario_hash_of(r.config_json);
    text += hash.empty() ? ")" : ", content hash " + hash + ")";
  }
  return text.empty() ? "there is no unfinished run in it" : "its unfinished runs: " + text;
}

// What differs between two run configurations (JSON), leaf by leaf: "/parameters/cp_duration_s: stored
// 23400, given 43200; ..." (at most 5, then how many more); both texts whole if either is not JSON.
std::string config_difference(const std::string& stored_text, const std::string& given_text) {
  const auto stored = nlohmann::json::parse(stored_text, nullptr, false);
  const auto given = nlohmann::json::parse(given_text, nullptr, false);
  if (stored.is_discarded() || given.is_discarded()) return stored_text + "; given: " + given_text;
  const auto a = stored.flatten(), b = given.flatten();
  std::vector<std::string> lines;
  for (const auto& [key, value] : a.items())
    if (!b.contains(key)) lines.push_back(key + ": stored " + value.dump() + ", not given");
    else if (b[key] != value) lines.push_back(key + ": stored " + value.dump() + ", given " + b[key].dump());
  for (const auto& [key, value] : b.items())
    if (!a.contains(key)) lines.push_back(key + ": not stored, given " + value.dump());
  std::string text;
  for (std::size_t k = 0; k < lines.size() && k < 5; ++k) text += (k ? "; " : "") + lines[k];
  if (lines.size() > 5) text += "; and " + std::to_string(lines.size() - 5) + " more";
  return text;
}

RunLifecycle::RunLifecycle(storage::HistoryWriter& writer, const std::filesystem::path& db,
                           const storage::RunRecord& record, double snapshot_every_s, Resume)
    : writer_(writer), snapshot_every_s_(snapshot_every_s) {
  // The reader is closed before the writer changes the file.
  const std::optional<storage::RunRecord> found = [&] {
    const storage::HistoryReader history(db);
    const std::vector<storage::RunRecord> runs = history.runs();
    std::optional<storage::RunRecord> run = run_to_resume(runs, record.source, record.config_json);
    if (!run) {
      const std::string hash = scenario_hash_of(record.config_json);
      throw ResumeRefused(db.string() + ": no unfinished run of '" + record.source + "'" +
                          (hash.empty() ? "" : " (content hash " + hash + ")") + " with this identity to resume; " +
                          unfinished_runs_text(history, runs));
    }
    return run;
  }();
  if (found->source != record.source)
    // Said at warn (the default log level shows it): the user named another file than the run's.
    log::get("runtime")->warn("run {} of '{}' is continued as '{}': the same data (content hash {}) and identity",
                              found->run_id, found->source, record.source, scenario_hash_of(record.config_json));
  // Another recording under the same name: say so (both content hashes) rather than "other parameters".
  if (const std::string stored = scenario_hash_of(found->config_json), given = scenario_hash_of(record.config_json);
      stored != given)
    throw ResumeRefused(db.string() + ": run " + std::to_string(found->run_id) + " of '" + record.source +
                        "' was recorded from other data: content hash " + (stored.empty() ? "(none)" : stored) +
                        " stored, " + (given.empty() ? "(none)" : given) + " given (another recording under the same name?)",
                        found->run_id);
  if (found->config_json != record.config_json)
    throw ResumeRefused(db.string() + ": run " + std::to_string(found->run_id) + " of '" + record.source +
                        "' was started with other parameters: " + config_difference(found->config_json, record.config_json),
                        found->run_id);
  // Other channels (the supervisor's [signals] changed, another file under the same name): say which.
  const auto names = [](const std::vector<std::string>& v) {
    std::string t;
    for (const auto& n : v) t += (t.empty() ? "" : ", ") + n;
    return "[" + t + "]";
  };
  for (const auto& [kind, stored, given] :
       {std::tuple{"inputs", &found->input_names, &record.input_names},
        std::tuple{"outputs", &found->output_names, &record.output_names},
        std::tuple{"offsets", &found->offset_names, &record.offset_names}})
    if (*stored != *given)
      throw ResumeRefused(db.string() + ": run " + std::to_string(found->run_id) + " of '" + record.source +
                          "' was recorded with other " + kind + ": stored " + names(*stored) + ", given " +
                          names(*given),
                          found->run_id);
  run_ = found->run_id;
  // The latest snapshot that decodes (format, checksum): a damaged later one is named and skipped, a
  // run without any usable snapshot is refused unchanged.
  storage::ResumePoint point;
  bool unreadable = false;
  try {
    // The learning history's samples are read back after the records past the snapshot are deleted:
    // judged before, so a resume that cannot read them changes nothing (before, the stop's indicators
    // were gone and the run read 'running').
    // A sample that cannot be read is a damaged history (exit 1), not a resume refused (exit 2).
    const std::size_t inputs = record.input_names.size();
    point = writer_.resume_run(run_, run_state_problem, [&](const storage::ControllerSnapshot& snap) -> std::string {
      try {
        load_run_state(db, run_, snap, inputs);
      } catch (const std::exception& e) {
        unreadable = true;
        return e.what();
      }
      return {};
    });
  } catch (const storage::StorageError& e) {
    if (e.kind != storage::StorageErrorKind::Corrupt || unreadable) throw;
    throw ResumeRefused(e.what(), run_);
  }
  for (const std::string& skipped : point.skipped)
    log::get("runtime")->warn("{}: run {}: {}; resuming from the latest good one, snapshot {} at t = {} s", db.string(),
                              run_, skipped, point.snapshot.snapshot_id, point.snapshot.time_s);
  resumed_from_ = point.snapshot;
  log::get("runtime")->info("run {} of '{}' resumed from its snapshot at t = {} s (sample {})", run_, record.source,
                            point.snapshot.time_s, point.snapshot.next_sample_index);
}

void RunLifecycle::save_snapshot(const Controller& controller, std::int64_t next_index) {
  const ControllerState& c = controller.state();
  storage::ControllerSnapshot snap;
  snap.run_id = run_;
  snap.next_sample_index = next_index;
  snap.time_s = c.started ? c.now_s : storage::kSnapshotBeforeStart_s;
  snap.format = kRunStateFormat;
  snap.is_json = false;
  snap.payload = encoder_ ? encoder_(next_index) : std::string();
  writer_.save_snapshot(snap);
  log::get("runtime")->debug("run {}: snapshot at t = {} s, {} bytes", run_, snap.time_s, snap.payload.size());
  // Before the first sample the start time is not known yet: on_sample_done() counts from it then.
  next_snapshot_s_ = c.started ? c.now_s + snapshot_every_s_ : -kInf;
}

void RunLifecycle::on_sample_done(const Sample&, const Controller& controller, std::int64_t next_index) {
  const ControllerState& c = controller.state();
  if (next_snapshot_s_ == -kInf) next_snapshot_s_ = c.start_time_s + snapshot_every_s_;
  if (c.now_s >= next_snapshot_s_) save_snapshot(controller, next_index);
}

void RunLifecycle::record_delivery(const std::string& sink, bool delivered, const std::string& message) {
  writer_.record_delivery(run_, sink, delivered, message);
  if (!delivered) log::get("runtime")->warn("run {}: NC output to {} not delivered: {}", run_, sink, message);
}

void RunLifecycle::end(bool finished, const std::optional<nlohmann::json>& indicators) {
  if (indicators) writer_.store_indicators({run_, indicators->dump(), 0.0});  // committed by end_run
  writer_.end_run(run_, finished ? storage::RunStatus::Finished : storage::RunStatus::Stopped);
  log::get("runtime")->info("run {} {}", run_, finished ? "finished" : "stopped (resumable)");
}

}  // namespace alc::runtime
