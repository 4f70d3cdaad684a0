#include "runtime/replay.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "common/number_text.hpp"
#include "probing/recorded_probes.hpp"
#include "runtime/history_recorder.hpp"
#include "runtime/report_json.hpp"
#include "runtime/run_state.hpp"
#include "storage/history_reader.hpp"
#include "storage/storage_error.hpp"

namespace alc::runtime {

namespace {
double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}
}  // namespace

Replay::Replay(const scenarios::Scenario& scenario, ReplayOptions options)
    : scenario_(scenario),
      options_(std::move(options)),
      controller_(scenario.input_names, scenario.output_names, options_.parameters, options_.schedule),
      source_(scenario),
      evaluation_(scenario, options_.baselines),
      driver_(controller_) {
  if (const std::string why = resume_problem(options_.resume, options_.baselines); !why.empty())
    throw ResumeRefused(why);
  driver_.add(evaluation_);
  driver_.set_requests(options_.probe_requests);
  const bool machine = !options_.db.empty() || options_.nc.has_value();
  if (machine) driver_.set_machine({options_.machine.chain, {}});
  if (!options_.db.empty()) {
    storage::WriterOptions w;
    w.create_directories = !options_.resume;
    w.must_exist = options_.resume;  // a resume never creates or initialises a history
    try {
      writer_ = std::make_unique<storage::HistoryWriter>(options_.db, w);
    } catch (const storage::StorageError& e) {
      if (e.kind == storage::StorageErrorKind::NotFound && options_.resume) throw ResumeRefused(e.what());
      throw;
    }
    const storage::RunRecord record = run_record();
    if (options_.resume) {
      lifecycle_ = std::make_unique<RunLifecycle>(*writer_, options_.db, record, options_.snapshot_every_s,
                                                  RunLifecycle::Resume{});
      restore(*lifecycle_->resumed_from());
      if (!options_.nc) {
        // What the NC got up to the snapshot (the records after it were deleted by the resume).
        NcOutputEnded ended;
        ended.from_s = lifecycle_->resumed_from()->time_s;
        for (const auto& c : storage::HistoryReader(options_.db).nc_commands(lifecycle_->run())) {
          if (std::find(ended.sinks.begin(), ended.sinks.end(), c.sink) == ended.sinks.end()) ended.sinks.push_back(c.sink);
          if (c.accepted && !c.delivered) ++ended.not_settled;
          if (c.accepted && c.delivered == false) ++ended.not_delivered;
        }
        if (!ended.sinks.empty()) nc_output_ended_ = std::move(ended);
      }
    } else {
      lifecycle_ = std::make_unique<RunLifecycle>(*writer_, record, options_.snapshot_every_s);
    }
    lifecycle_->set_encoder([this](std::int64_t) { return encode_state(); });
    recorder_ = std::make_unique<HistoryRecorder>(*writer_, lifecycle_->run(), !record.offset_names.empty());
    driver_.add(*recorder_);
  }
  if (options_.nc) {
    NcObserverOptions o = nc_observer_options(options_.machine);
    o.dialect = options_.nc->dialect;
    nc_.emplace(scenario.output_names, o);
    if (writer_)
      nc_->set_history({writer_.get(), lifecycle_->run(), nc_sink_name(options_.nc->dir), options_.nc->dialect,
                        options_.machine.nc});
    driver_.add(*nc_);
  }
  if (lifecycle_) {
    driver_.add(*lifecycle_);  // after the recorders: a snapshot commits what they added
    if (!options_.resume) lifecycle_->save_snapshot(controller_, 0);  // a killed run can always resume
  }
  for (Observer* o : options_.observers) driver_.add(*o);
}

Replay::~Replay() = default;

std::string sparse_measurements(const scenarios::Scenario& scenario, const AlcParameters& parameters,
                                const std::string& what) {
  if (scenario.time_s.empty()) return {};
  // The median spacing of the measured rows in [from_s, until_s] (NaN with fewer than 3): the rows a
  // probe can take, as the recorded source finds them.
  const probing::RecordedProbes probes(scenario.time_s, scenario.outputs);
  const auto median_spacing = [&](double from_s, double until_s) {
    std::vector<double> gaps;
    double last = std::numeric_limits<double>::quiet_NaN();
    for (const std::size_t r : probes.measured_rows()) {
      const double t = scenario.time_s[r];
      if (t > until_s) break;
      if (t < from_s) continue;
      if (!std::isnan(last)) gaps.push_back(t - last);
      last = t;
    }
    if (gaps.size() < 2) return std::numeric_limits<double>::quiet_NaN();
    std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2), gaps.end());
    return gaps[gaps.size() / 2];
  };
  const auto minutes = [](double s) { return common::shortest_text(std::round(s / 6.0) / 10.0) + " min"; };
  std::vector<std::string> parts;
  const double cp_end_s = scenario.time_s.front() + parameters.cp_duration_s;
  const double in_cp = median_spacing(-std::numeric_limits<double>::infinity(), cp_end_s);
  // 1.5 x: a recording measured on a slightly coarser grid than the interval (7 min against 5) is
  // the case the schedule's "next measurement" rule is for, and still probes about as often.
  if (in_cp > 1.5 * parameters.cp_interval_s)
    parts.push_back("in CP every " + minutes(in_cp) + " (median) where the CP interval is " +
                    minutes(parameters.cp_interval_s) + ", so CP gets fewer probes than its schedule");
  const double after_cp = median_spacing(cp_end_s, std::numeric_limits<double>::infinity());
  if (std::isfinite(parameters.ng_interval_s) && after_cp > 1.5 * parameters.ng_interval_s)
    parts.push_back("after CP every " + minutes(after_cp) + " (median) where the NG interval is " +
                    minutes(parameters.ng_interval_s) + ", so an NG burst is stretched");
  if (parts.empty()) return {};
  std::string text = what + " is measured more sparsely than the schedule asks (a probe takes the next recorded "
                            "measurement): ";
  for (std::size_t i = 0; i < parts.size(); ++i) text += (i ? "; " : "") + parts[i];
  return text;
}

std::string scenario_problem(const scenarios::Scenario& scenario, const AlcParameters& parameters,
                             const std::string& what, const ScenarioOptionTexts& texts) {
  if (scenario.time_s.empty()) return {};
  const auto hours = [](double s) { return common::shortest_text(s / 3600.0); };
  const auto named = [&](const std::string& option, const std::string& text, double value_s) {
    return option + " " + (text.empty() ? hours(value_s) : text) + " h";
  };
  const auto since = [&] { return named(texts.since_option, texts.since, parameters.learning_since_s); };
  // Learning from a time the recording never reaches: no fit, CP without end, a table of dashes. And
  // one before it begins: --since counts from scenario time 0 (a file stamped in Unix time starts at
  // ~470,000 h), so --since 26 meant as "26 h in" would silently change nothing.
  if (parameters.learning_since_s > scenario.time_s.back())
    return since() + " is after the end of " + what + " (its last sample is at " + hours(scenario.time_s.back()) +
           " h of scenario time): the controller would never learn from a probe";
  // A recording without a single measurement: the same table of dashes, and Pd 100 %.
  if (!scenario.outputs.array().isFinite().any())
    return what + " has no probe measurement (its " + std::to_string(scenario.output_names.size()) +
           " error columns are empty on every row): CP would not end, no model would be made and nothing "
           "evaluated";
  // A CP longer than the recording: no model, nothing evaluated, a table of dashes.
  if (scenario.time_s.front() + parameters.cp_duration_s > scenario.time_s.back())
    return named(texts.cp_option, texts.cp, parameters.cp_duration_s) + " is longer than " + what + " (" +
           hours(scenario.time_s.back() - scenario.time_s.front()) +
           " h): CP would not end, no model would be made and nothing evaluated";
  if (parameters.learning_since_s > 0.0 && parameters.learning_since_s < scenario.time_s.front())
    return since() + " is before the first sample of " + what + " (at " + hours(scenario.time_s.front()) +
           " h of scenario time) and would change nothing: it counts from scenario time 0, not from the first "
           "sample";
  return {};
}

std::string resume_problem(bool resume, const std::vector<BaselineKind>& baselines) {
  if (!resume || baselines.empty()) return {};
  return "baselines cannot be evaluated on a resumed run (they are fitted once at the end of CP and not kept by "
         "its snapshots); replay without --resume";
}

std::string replay_identity(const ReplayOptions& options) {
  const auto schedule = options.schedule ? options.schedule : options.parameters.schedule_policy();
  nlohmann::json identity = {{"parameters", canonical_parameters(options.parameters, schedule->name())}};
  for (const auto& [k, v] : options.identity.items()) identity[k] = v;
  return identity.dump();
}

storage::RunRecord Replay::run_record() const {
  storage::RunRecord r;
  r.source = options_.source;
  r.config_json = replay_identity(options_);
  r.software_version = options_.software_version;
  r.input_names = scenario_.input_names;
  r.output_names = scenario_.output_names;
  // The offsets derived from each prediction, when an output is a C-axis error.
  r.offset_names = HistoryRecorder::offset_names(options_.machine.chain, scenario_.output_names);
  return r;
}

std::string Replay::encode_state() const {
  RunState s;
  s.next_index = static_cast<std::int64_t>(source_.position());
  s.controller = controller_.state();
  s.baseline_fitted = evaluation_.baseline_fitted();
  s.baseline = evaluation_.baseline();
  s.identification_s = driver_.identification_s();
  s.total_s = total_s_;
  return encode_run_state(s);
}

void Replay::restore(const storage::ControllerSnapshot& snapshot) {
  RunState s = load_run_state(options_.db, *run_id(), snapshot, scenario_.input_names.size());
  if (s.next_index < 0 || static_cast<std::size_t>(s.next_index) > scenario_.samples())
    throw std::runtime_error(options_.db.string() + ": the snapshot continues at row " +
                             std::to_string(s.next_index) + ", beyond the " + std::to_string(scenario_.samples()) +
                             " rows of " + options_.source);
  // The evaluation is rebuilt from the stored predictions (the prediction active at each evaluated row).
  const storage::HistoryReader reader(options_.db);
  const auto samples = reader.input_samples(*run_id());
  const auto predictions = reader.predictions(*run_id());
  if (predictions.size() != samples.size())
    throw std::runtime_error(options_.db.string() + ": run " + std::to_string(*run_id()) + " stores " +
                             std::to_string(samples.size()) + " samples and " + std::to_string(predictions.size()) +
                             " predictions before its snapshot");
  evaluation_.restore_baseline(s.baseline_fitted, s.baseline);
  const double cp_end_s = s.controller.cp_end_s;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const auto& p = predictions[k].predicted;
    evaluation_.rebuild(static_cast<std::size_t>(samples[k].sample_index),
                        Eigen::Map<const Eigen::VectorXd>(p.data(), static_cast<Eigen::Index>(p.size())), cp_end_s);
  }
  controller_ = Controller(scenario_.input_names, scenario_.output_names, options_.parameters,
                           std::move(s.controller), options_.schedule);
  driver_.set_identification_s(s.identification_s);
  total_s_ = s.total_s;
  source_.seek(static_cast<std::size_t>(s.next_index));
}

std::optional<storage::RunId> Replay::run_id() const {
  if (!lifecycle_) return std::nullopt;
  return lifecycle_->run();
}

void Replay::run() { run_until(options_.stop_time_s); }

void Replay::advance(double stop_time_s) {
  const auto start = std::chrono::steady_clock::now();
  driver_.run(source_, stop_time_s);
  total_s_ += seconds_since(start);
}

void Replay::run_until(double stop_time_s) {
  advance(stop_time_s);
  if (ended_) return;
  ended_ = true;
  if (lifecycle_) {
    lifecycle_->save_snapshot(controller_, static_cast<std::int64_t>(source_.position()));
    // The indicators as `alc replay --json` prints them, with the end: what a report of the run shows.
    lifecycle_->end(finished(), report_json(report()));
  }
  if (nc_) {
    const std::string sink = nc_sink_name(options_.nc->dir);
    try {
      nc_summary_ = nc::write_replay_nc_output(options_.nc->dir, options_.nc->dialect, nc_->commands(),
                                               options_.machine.nc, options_.machine.limits);
    } catch (const std::exception& e) {
      if (lifecycle_) lifecycle_->record_delivery(sink, false, e.what());
      if (writer_) writer_->close();
      throw;
    }
    if (lifecycle_) lifecycle_->record_delivery(sink, true, "written to " + nc_summary_->program_file.string());
  }
  if (writer_) writer_->close();
}

ReplayReport Replay::report() const {
  ReplayReport r = evaluation_.report(controller_, source_.position());
  r.identification_s = driver_.identification_s();
  r.total_s = total_s_;
  return r;
}

ReplayReport replay(const scenarios::Scenario& scenario, const AlcParameters& parameters) {
  ReplayOptions o;
  o.parameters = parameters;
  Replay r(scenario, std::move(o));
  r.run();
  return r.report();
}

}  // namespace alc::runtime
