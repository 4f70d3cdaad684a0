// alc replay: run the ALC controller over a recorded or built-in load case and print the paper's
// indicators beside a static baseline.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <initializer_list>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <vector>

#include "alc_version.hpp"
#include "commands.hpp"
#include "common/log.hpp"
#include "common/number_text.hpp"
#include "nc_interface/dialects.hpp"
#include "nc_interface/machine_config.hpp"
#include "nc_interface/recorder.hpp"
#include "runtime/parameter_options.hpp"
#include "runtime/replay.hpp"
#include "runtime/report_json.hpp"
#include "scenarios/load_cases.hpp"
#include "scenarios/scenario_csv.hpp"
#include "storage/history_reader.hpp"

namespace alc::cli {

namespace {

constexpr double kMaxHours = 1e9;  // [h] largest --stop-at, --kill-at (beyond any scenario)

struct ReplayArgs {
  std::string file;
  std::string case_name;
  std::uint64_t seed = 0;
  bool seed_given = false;
  std::string adaptive_option_given;  // the first of the adaptive schedule's options given, "" = none
  std::string cp = "6.5", cp_interval = "5", interval = "2", ng_interval = "10", ng_meas = "12", update = "inf";
  std::string acl_lin = "5", acl_ang = "15";
  std::string window = common::shortest_text(AlcParameters{}.learning_window_s / 3600.0);  // [h] 336 = 14 d
  std::string half_life = "inf", method = "fixed-poles";
  std::string since;           // [h] of scenario time: learn only from probes at or after it; "" = all
  std::string max_order = std::to_string(IdentificationOptions{}.max_order);
  bool json = false;
  bool no_refit = false;
  bool no_confirm = false;
  std::string schedule = "paper", uncertainty_fraction = "0.5", min_interval = "0.5", max_interval = "12";
  bool guard = false;          // --guard: the default since the gain guard (kept so old command lines work)
  bool no_guard = false;
  std::string move_fraction = common::shortest_text(AlcParameters{}.move_fraction);
  bool move_fraction_given = false;
  // [µm], [µm/m], [°C], [rpm], [-]: readings beyond ± these are sensor faults (AlcParameters::plausible_*)
  std::string plausible_lin = common::shortest_text(AlcParameters{}.plausible_linear_um);
  std::string plausible_ang = common::shortest_text(AlcParameters{}.plausible_angular_um_per_m);
  std::string plausible_temp = common::shortest_text(AlcParameters{}.plausible_temperature_C);
  std::string plausible_speed = common::shortest_text(AlcParameters{}.plausible_speed_rpm);
  std::string plausible_other = common::shortest_text(AlcParameters{}.plausible_other);
  std::string structure_refresh = "1.25";  // factor of data-span growth that triggers a structure search
  std::string db;              // history database, "" = none
  double stop_at_h = kInf;     // [h] of scenario time
  std::vector<double> probe_at_h;  // [h] of scenario time: probes asked for (--probe-at), ascending, distinct
  bool resume = false;
  double kill_at_h = kInf;     // [h] fault injection for tests: SIGKILL itself at this scenario time
  std::string residuals;
  std::string nc_out;          // directory for the NC output, "" = none
  std::string dialect = "linuxcnc";
  std::string machine;         // machine config (TOML), "" = built-in defaults
  std::string baselines;       // the seeds' static models beside ALC: "mlr,svr", "all"; "" = none
};

// The parameters of the options given (one parser for replay's options and a study grid's keys).
AlcParameters parameters_from(const ReplayArgs& a) {
  runtime::OptionTexts o = {{"cp", a.cp},           {"cp-interval", a.cp_interval}, {"interval", a.interval},
                            {"ng-interval", a.ng_interval}, {"ng-meas", a.ng_meas},  {"update", a.update},
                            {"acl-lin", a.acl_lin}, {"acl-ang", a.acl_ang},         {"window", a.window},
                            {"half-life", a.half_life},     {"method", a.method},    {"max-order", a.max_order},
                            {"structure-refresh", a.structure_refresh},
                            {"no-refit", a.no_refit ? "true" : "false"},
                            {"no-confirm", a.no_confirm ? "true" : "false"},
                            {"schedule", a.schedule},
                            {"uncertainty-fraction", a.uncertainty_fraction},
                            {"min-interval", a.min_interval},
                            {"max-interval", a.max_interval},
                            {"guard", a.no_guard ? "false" : "true"},
                            {"move-fraction", a.move_fraction},
                            {"plausible-lin", a.plausible_lin},
                            {"plausible-ang", a.plausible_ang},
                            {"plausible-temp", a.plausible_temp},
                            {"plausible-speed", a.plausible_speed},
                            {"plausible-other", a.plausible_other}};
  if (!a.since.empty()) o.emplace_back("since", a.since);
  try {
    return runtime::parameters_of(o);
  } catch (const runtime::InvalidParameters& e) {
    throw UsageError(e.what());  // the controller's constraint, no option to name
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--") + e.what());  // "max-interval: ..." names the option
  }
}

std::string fmt(double v, int precision = 2) {
  if (std::isnan(v)) return "-";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", precision, v);
  return buf;
}

// " (the mean of 3 of 4 outputs; E_X0C has no P99: no plausible measurement after CP)" where some output of `kind` has no
// P99 and the mean is over the others, so that a recording with an output left out does not read as
// the better one; "" where every output of that kind counts.
std::string mean_coverage(const runtime::ReplayReport& r, ErrorKind kind) {
  int of_kind = 0;
  std::vector<std::string> missing;
  for (const auto& o : r.outputs) {
    if (o.kind != kind) continue;
    ++of_kind;
    if (std::isnan(o.P99)) missing.push_back(o.name);
  }
  if (missing.empty() || static_cast<int>(missing.size()) == of_kind) return {};
  std::string names;
  for (const auto& m : missing) names += (names.empty() ? "" : ", ") + m;
  return " (the mean of " + std::to_string(of_kind - static_cast<int>(missing.size())) + " of " +
         std::to_string(of_kind) + " outputs; " + names + (missing.size() == 1 ? " has" : " have") +
         " no P99: no plausible measurement after CP)";
}

void print_report(std::ostream& os, const std::string& title, const runtime::ReplayReport& r) {
  os << title << "\n";
  os << "  duration " << fmt(r.duration_s / 3600.0, 1) << " h, CP ended at "
     << (std::isfinite(r.cp_end_s) ? fmt(r.cp_end_s / 3600.0, 2) + " h" : std::string("never")) << ", M = " << r.M
     << " probe cycles, Pd = " << fmt(r.Pd) << " %, NG phases " << r.ng_phases << ", model updates " << r.updates
     << (r.rejected_fits ? ", rejected fits " + std::to_string(r.rejected_fits) : std::string())
     << (r.rejected_samples ? ", samples set aside " + std::to_string(r.rejected_samples) : std::string()) << "\n";
  char line[256];
  std::snprintf(line, sizeof line, "  %-8s %-5s %8s %8s %8s %9s %12s %13s\n", "output", "unit", "PV[%]", "RMSE",
                "P99", "SMAPE[%]", "P99 uncomp", "P99 baseline");
  os << line;
  for (std::size_t i = 0; i < r.outputs.size(); ++i) {
    const auto& o = r.outputs[i];
    std::snprintf(line, sizeof line, "  %-8s %-5s %8s %8s %8s %9s %12s %13s\n", o.name.c_str(),
                  std::string(unit_of(o.kind)).c_str(), fmt(o.PV, 1).c_str(), fmt(o.RMSE).c_str(), fmt(o.P99).c_str(),
                  fmt(o.SMAPE, 1).c_str(), fmt(o.P99_uncompensated).c_str(), fmt(r.baseline[i].P99).c_str());
    os << line;
  }
  os << "  mean P99 linear: ALC " << fmt(r.mean_p99(ErrorKind::Linear)) << " µm, baseline "
     << fmt(r.mean_p99(ErrorKind::Linear, true)) << " µm, uncompensated "
     << fmt(r.mean_p99_uncompensated(ErrorKind::Linear)) << " µm" << mean_coverage(r, ErrorKind::Linear) << "\n";
  os << "  mean P99 angular: ALC " << fmt(r.mean_p99(ErrorKind::Angular)) << " µm/m, baseline "
     << fmt(r.mean_p99(ErrorKind::Angular, true)) << " µm/m, uncompensated "
     << fmt(r.mean_p99_uncompensated(ErrorKind::Angular)) << " µm/m" << mean_coverage(r, ErrorKind::Angular) << "\n";
  for (const auto& b : r.baselines) {
    std::snprintf(line, sizeof line, "  %-6s mean P99 linear %8s µm, angular %8s µm/m", b.name.c_str(),
                  fmt(b.mean_p99(ErrorKind::Linear)).c_str(), fmt(b.mean_p99(ErrorKind::Angular)).c_str());
    os << line;
    if (!b.selected.empty()) {
      os << "; inputs selected:";
      for (const auto& [output, inputs] : b.selected) {
        os << " " << output << " ";
        for (std::size_t i = 0; i < inputs.size(); ++i) os << (i ? "," : "") << inputs[i];
        if (inputs.empty()) os << "none";
      }
    }
    // Fewer CP measurements than parameters: the figures are those of no fit (0 or 1: it predicts 0).
    std::string under;
    for (const auto& [output, count] : b.fitted_on)
      if (count < b.parameters) under += " " + output + " " + std::to_string(count);
    if (!under.empty())
      os << "; underdetermined (fewer CP measurements than its " << b.parameters << " parameters, inputs + 1):"
         << under;
    os << "\n";
  }
}

double mean_over(const std::vector<runtime::OutputIndicators>& outs, double runtime::OutputIndicators::*f) {
  double s = 0.0;
  int n = 0;
  for (const auto& o : outs)
    if (!std::isnan(o.*f)) {
      s += o.*f;
      ++n;
    }
  return n ? s / n : std::nan("");
}

// One line per case, like Tab. 3 of seed 004 (SMAPE, RMSE, PV averaged over all errors; P99 over
// the linear errors), with the baseline and the uncompensated P99 beside it.
void print_table3(std::ostream& os, const std::vector<std::pair<std::string, runtime::ReplayReport>>& rows) {
  char line[256];
  std::snprintf(line, sizeof line, "%-5s %9s %9s %7s %9s %11s %7s %5s %4s %4s %14s %12s\n", "case", "SMAPE[%]",
                "RMSE[µm]", "PV[%]", "P99[µm]", "P99ang", "Pd[%]", "M", "NG", "upd", "baseline P99", "uncomp P99");
  os << line;
  for (const auto& [name, r] : rows) {
    std::snprintf(line, sizeof line, "%-5s %9s %9s %7s %9s %11s %7s %5d %4d %4d %14s %12s\n", name.c_str(),
                  fmt(mean_over(r.outputs, &runtime::OutputIndicators::SMAPE)).c_str(),
                  fmt(mean_over(r.outputs, &runtime::OutputIndicators::RMSE)).c_str(),
                  fmt(mean_over(r.outputs, &runtime::OutputIndicators::PV)).c_str(),
                  fmt(r.mean_p99(ErrorKind::Linear)).c_str(), fmt(r.mean_p99(ErrorKind::Angular)).c_str(),
                  fmt(r.Pd).c_str(), r.M, r.ng_phases, r.updates, fmt(r.mean_p99(ErrorKind::Linear, true)).c_str(),
                  fmt(r.mean_p99_uncompensated(ErrorKind::Linear)).c_str());
    os << line;
  }
  if (rows.empty() || rows.front().second.baselines.empty()) return;
  // The seeds' static models beside ALC: mean linear P99 per case.
  os << "\nmean linear P99 [µm]\n" << std::left;
  os << "  " << std::setw(5) << "case" << std::right << std::setw(8) << "ALC";
  for (const auto& b : rows.front().second.baselines) os << std::setw(8) << b.name;
  os << std::setw(8) << "uncomp" << "\n";
  for (const auto& [name, r] : rows) {
    os << "  " << std::left << std::setw(5) << name << std::right << std::setw(8) << fmt(r.mean_p99(ErrorKind::Linear));
    for (const auto& b : r.baselines) os << std::setw(8) << fmt(b.mean_p99(ErrorKind::Linear));
    os << std::setw(8) << fmt(r.mean_p99_uncompensated(ErrorKind::Linear)) << "\n";
  }
}

// More of the run's identity than the parameters (which are stored as parsed values): what the
// parameters do not say but the results depend on, the data included (scenarios::content_hash: a
// --resume with another recording under the same file name is refused).
nlohmann::json identity_of(const ReplayArgs& a, const std::string& name, const scenarios::Scenario& scenario,
                           const nc::MachineConfig& machine) {
  nlohmann::json j = nlohmann::json::object();
  j["scenario_hash"] = scenarios::content_hash(scenario);
  // A seed other than the case's own (--seed 101 for A is the run without --seed, byte for byte).
  const auto info = a.file.empty() ? scenarios::find_case(name) : std::nullopt;
  if (a.seed_given && !(info && info->default_seed == a.seed)) j["seed"] = a.seed;
  // Its chain gives the stored offsets: --resume must repeat the machine, by content (the same file by
  // another path is the same machine; the file edited is another one).
  if (!a.machine.empty()) j["machine_hash"] = machine.content_hash;
  // The probes asked for change the run's decisions: a --resume must ask for the same.
  if (!a.probe_at_h.empty()) j["probe_at_h"] = a.probe_at_h;
  return j;
}

// Fault injection for tests of crash safety: SIGKILLs the process after the first sample at or past
// a scenario time (after the history's observers have seen it).
struct KillSwitch : runtime::Observer {
  double kill_at_s = kInf;
  void on_sample_done(const runtime::Sample&, const Controller& controller, std::int64_t) override {
    if (controller.state().now_s >= kill_at_s) std::raise(SIGKILL);
  }
};

// The NC output directory of one scenario: DIR itself, or DIR/<case> when several are replayed.
std::filesystem::path nc_dir_of(const ReplayArgs& a, const std::string& name, bool several) {
  return several ? std::filesystem::path(a.nc_out) / name : std::filesystem::path(a.nc_out);
}

// One summary line of the NC output on stderr.
void print_nc_summary(const std::string& source, const std::filesystem::path& dir, nc::Dialect dialect,
                      const runtime::NcCommandObserver& observer, const nc::NcOutputSummary& s) {
  std::cerr << source << ": NC output in " << dir.string() << ": " << s.requested << " commands, " << s.refused
            << " refused, " << s.split << " split, " << s.sent << " written (" << nc::dialect_name(dialect) << ")";
  if (!observer.maps_any_error()) std::cerr << "; no output named E_X0C … E_C0C, so no axis offsets";
  else
    std::cerr << "; largest non-compensable tilt " << observer.max_non_compensable_um_per_m()
              << " µm/m (no axis to cancel it; per command in commands.jsonl)";
  if (observer.not_converged())
    std::cerr << "; " << observer.not_converged() << " moments without a converged compensation";
  std::cerr << "\n";
  for (const std::filesystem::path& old : s.removed)
    std::cerr << source << ": removed " << old.string() << ", the program of an earlier run in another dialect (this run's is "
              << s.program_file.string() << ")\n";
}

enum class ResumePlan { Begin, Resume, Stored };

// Per source (with the identity it would store): Resume its latest unfinished run (running or
// stopped: the run RunLifecycle resumes); else Stored for its latest finished run (its stored
// indicators in `stored`); else Begin. Refused (UsageError) before anything is changed when a run to
// resume or to show has another identity (parameters or data), or when nothing is left to resume (no
// run at all, or every one finished).
std::vector<ResumePlan> plan_resume(const std::string& db, const std::vector<std::pair<std::string, std::string>>& sources,
                                    std::vector<std::optional<runtime::ReplayReport>>& stored) {
  const storage::HistoryReader history(db);
  const auto runs = history.runs();
  std::vector<ResumePlan> plans;
  bool any_run = false, any_open = false;
  for (std::size_t k = 0; k < sources.size(); ++k) {
    const auto& [source, identity] = sources[k];
    // The run RunLifecycle would resume, else the latest finished one.
    const std::optional<storage::RunRecord> open = runtime::run_to_resume(runs, source, identity);
    const storage::RunRecord* latest = nullptr;
    for (const auto& r : runs)
      if (r.source == source && r.status == storage::RunStatus::Finished) latest = &r;
    if (!open && latest == nullptr) {
      plans.push_back(ResumePlan::Begin);
      continue;
    }
    any_run = true;
    const storage::RunRecord& run = open ? *open : *latest;
    // Judged here for every case, so that no case is begun or resumed before another is refused.
    if (run.config_json != identity)
      throw UsageError(db + ": the " + (open ? "unfinished" : "finished") + " run " + std::to_string(run.run_id) +
                       " of '" + source + "' was made with other parameters or data (" +
                       runtime::config_difference(run.config_json, identity) +
                       "); nothing was changed; resume the cases one by one or give another --db");
    if (open) {
      plans.push_back(ResumePlan::Resume);
      any_open = true;
      continue;
    }
    const auto indicators = history.indicators(latest->run_id);
    if (!indicators)
      throw UsageError(db + ": the finished run " + std::to_string(latest->run_id) + " of '" + source +
                       "' has no stored indicators to show");
    stored[k] = runtime::report_from_json(nlohmann::json::parse(indicators->report_json), latest->output_names);
    plans.push_back(ResumePlan::Stored);
  }
  if (!any_run) throw UsageError(db + ": no run of these cases to resume");
  if (!any_open && std::find(plans.begin(), plans.end(), ResumePlan::Begin) == plans.end())
    throw UsageError(db + ": nothing to resume: every case's run is finished");
  return plans;
}

void run_replay(const ReplayArgs& a) {
  if (a.file.empty() == a.case_name.empty()) throw UsageError("give exactly one of FILE.csv or --case");
  // It would be ignored, yet stored in the run's identity (a later --resume without it refused).
  if (!a.file.empty() && a.seed_given) throw UsageError("--seed applies to --case (a simulated load case), not to a FILE");
  const AlcParameters params = parameters_from(a);
  // Read only by the adaptive schedule: under the paper's it would be ignored and the run be the
  // default one, while the user believes it ran with that value (after the values are judged).
  if (!a.adaptive_option_given.empty() && a.schedule != "adaptive")
    throw UsageError(a.adaptive_option_given + " is for --schedule adaptive; under --schedule " + a.schedule +
                     " it would be ignored (give --schedule adaptive, or leave it out)");
  // Read only by the guard's move check, which needs the guard and the refits on probes.
  if (a.move_fraction_given && (a.no_guard || a.no_refit))
    throw UsageError(std::string("--move-fraction is for the guard's move check; with ") +
                     (a.no_guard ? "--no-guard" : "--no-refit") + " it would be ignored (leave one of them out)");
  std::vector<BaselineKind> baselines;
  if (!a.baselines.empty()) {
    try {
      baselines = parse_baseline_list(a.baselines);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--baselines: ") + e.what());
    }
  }
  // Before any case runs (with several cases, one might be begun before another is resumed).
  if (const std::string why = runtime::resume_problem(a.resume, baselines); !why.empty())
    throw UsageError("--" + why);
  std::vector<std::pair<std::string, scenarios::Scenario>> cases;
  if (!a.file.empty()) {
    cases.emplace_back(a.file, scenarios::read_scenario_csv(a.file));
  } else {
    for (const auto& name : load_case_names(a.case_name)) {
      auto simulated = scenarios::simulate_case(name, a.seed_given ? std::optional<std::uint64_t>(a.seed) : std::nullopt);
      cases.emplace_back(name, std::move(simulated.scenario));
    }
  }
  if (!a.residuals.empty() && cases.size() != 1) throw UsageError("--residuals needs a single scenario");
  refuse_output_over_input("--residuals", a.residuals, a.db, "the history database");
  refuse_output_over_input("--residuals", a.residuals, a.file, "the recording replayed");
  // The NC output directory is written whole (program files, commands.jsonl): --residuals in it would
  // replace one of them, or be replaced.
  if (!a.residuals.empty() && !a.nc_out.empty()) {
    std::error_code ec;
    const auto dir = std::filesystem::weakly_canonical(std::filesystem::absolute(a.nc_out), ec);
    const auto parent = std::filesystem::weakly_canonical(std::filesystem::absolute(a.residuals).parent_path(), ec);
    if (!ec && parent == dir)
      throw UsageError("--residuals " + a.residuals + " is in the --nc-out directory " + a.nc_out +
                       ", whose files the NC output writes; give another path");
  }
  // Judged before the replay (as alc simulate judges --out): a missing directory found only when the
  // residuals were written cost the whole replay, its run already stored in --db.
  refuse_unwritable_output("--residuals", a.residuals);
  for (const auto& [name, scenario] : cases) {
    const std::string what = (a.file.empty() ? "case " : "") + name;
    if (const std::string why = runtime::scenario_problem(scenario, params, what, {"--cp", a.cp, "--since", a.since});
        !why.empty())
      throw UsageError(why);
    // A probe asked for after the last sample would never be taken, silently.
    const double span_s = scenario.time_s.empty() ? 0.0 : scenario.time_s.back() - scenario.time_s.front();
    if (!a.probe_at_h.empty() && !scenario.time_s.empty() && a.probe_at_h.back() * 3600.0 > span_s)
      throw UsageError("--probe-at " + common::shortest_text(a.probe_at_h.back()) + " is after the last sample of " +
                       what + " (" + common::shortest_text(span_s / 3600.0) + " h from its first)");
  }
  if ((a.resume || std::isfinite(a.stop_at_h)) && a.db.empty()) throw UsageError("--stop-at and --resume need --db");
  nc::MachineConfig machine;
  nc::Dialect dialect = nc::Dialect::LinuxCNC;
  // The machine's chain gives the offsets of --nc-out and those stored with --db.
  if (!a.machine.empty() && a.nc_out.empty() && a.db.empty()) throw UsageError("--machine needs --nc-out or --db");
  if (a.nc_out == "-") throw UsageError("--nc-out writes a directory; '-' (stdout) is not offered");
  if (!a.machine.empty()) {
    try {
      machine = nc::read_machine_config(a.machine);
    } catch (const nc::ConfigError& e) {
      throw UsageError(e.what());
    }
  }
  // The programs it writes (--nc-out, the nc_commands text of --db) name alc replay as their writer.
  machine.nc.writer = nc::ProgramWriter::AlcReplay;
  // Without --machine they are the built-in twin's, whose work offsets are 0: a G10 L2 program says so,
  // as it would set a real machine's work offset to the compensation alone.
  if (a.machine.empty())
    machine.nc.base_note = "for the built-in twin, whose work offsets are 0: not for a real machine, "
                           "whose base alc replay --machine FILE gives";
  if (!a.nc_out.empty()) {
    if (a.resume)
      throw UsageError(
          "--nc-out cannot be combined with --resume (the safety gate would not know the offsets in force)");
    const auto dialect_parsed = nc::parse_dialect(a.dialect);
    if (!dialect_parsed)
      throw UsageError("--dialect: '" + a.dialect + "' is not one of linuxcnc, fanuc, sinumerik, heidenhain");
    dialect = *dialect_parsed;
    // A real machine's file must give the base that G10 L2 writes with; the built-in twin's work
    // offsets (no --machine) are zero by construction (docs/nc.md, "Base offsets").
    if (!a.machine.empty())
      if (const std::string why = nc::missing_base(dialect, machine.nc, machine.work_offset, machine.chain.tilt.name);
          !why.empty())
        throw UsageError("--machine " + a.machine + ": " + why);
  } else if (a.dialect != "linuxcnc") {
    throw UsageError("--dialect needs --nc-out");
  }

  // A file by the path given, written plainly (./rec.csv and rec.csv are one source; its content is in the
  // identity anyway).
  const auto source_of = [&](const std::string& name) {
    return a.file.empty() ? "case " + name : "file " + std::filesystem::path(name).lexically_normal().string();
  };
  const auto identity_options = [&](const std::string& name, const scenarios::Scenario& scenario) {
    runtime::ReplayOptions o;
    o.parameters = params;
    o.source = source_of(name);
    o.identity = identity_of(a, name, scenario, machine);
    return o;
  };
  // --resume of several cases (--case all after a kill): per case, its unfinished run is resumed, a
  // finished one is shown from its stored indicators, one never begun begins; decided before anything
  // is changed.
  std::vector<ResumePlan> plans(cases.size(), a.resume ? ResumePlan::Resume : ResumePlan::Begin);
  std::vector<std::optional<runtime::ReplayReport>> stored(cases.size());
  if (a.resume && cases.size() > 1) {
    std::vector<std::pair<std::string, std::string>> sources;  // (source, identity)
    for (const auto& [name, scenario] : cases)
      sources.emplace_back(source_of(name), runtime::replay_identity(identity_options(name, scenario)));
    plans = plan_resume(a.db, sources, stored);
  }

  // The NC output directories are made before any run begins, not when it ends: an --nc-out that
  // cannot be a directory (a file of that name, say) failed only after a whole replay, its commands
  // recorded in --db as not delivered.
  if (!a.nc_out.empty())
    for (const auto& c : cases) {
      const auto dir = nc_dir_of(a, c.first, cases.size() > 1);
      std::error_code ec;
      std::filesystem::create_directories(dir, ec);
      if (ec) throw std::runtime_error("--nc-out: cannot create " + dir.string() + ": " + ec.message());
    }

  KillSwitch kill;
  std::vector<std::pair<std::string, runtime::ReplayReport>> reports;
  std::map<std::string, double> stopped_at_h;  // per case stopped before its end: where [h], to 0.01 h
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const auto& [name, scenario] = cases[k];
    const std::string source = source_of(name);
    if (plans[k] == ResumePlan::Stored) {
      std::cerr << source << ": finished before (in " << a.db << "); its stored indicators are shown\n";
      reports.emplace_back(name, *stored[k]);
      continue;
    }
    const double t0 = scenario.time_s.empty() ? 0.0 : scenario.time_s.front();
    runtime::ReplayOptions o = identity_options(name, scenario);
    o.db = a.db;
    o.resume = plans[k] == ResumePlan::Resume;
    o.stop_time_s = std::isfinite(a.stop_at_h) ? t0 + a.stop_at_h * 3600.0 : kInf;
    for (const double h : a.probe_at_h)
      o.probe_requests.emplace_back(t0 + h * 3600.0, "--probe-at " + common::shortest_text(h) + " h");
    o.machine = machine;
    o.software_version = std::string("alc ") + ALC_VERSION;
    o.baselines = baselines;
    if (!a.nc_out.empty()) o.nc = runtime::NcOutputSetup{nc_dir_of(a, name, cases.size() > 1), dialect};
    kill.kill_at_s = std::isfinite(a.kill_at_h) ? t0 + a.kill_at_h * 3600.0 : kInf;
    if (std::isfinite(kill.kill_at_s)) o.observers.push_back(&kill);
    std::optional<runtime::Replay> replay;
    try {
      replay.emplace(scenario, std::move(o));
    } catch (const runtime::ResumeRefused& e) {
      throw UsageError(e.what());
    }
    // Said of a run that replays (not of one shown from its stored indicators), once nothing can refuse it.
    if (const std::string note = runtime::sparse_measurements(scenario, params, (a.file.empty() ? "case " : "") + name);
        !note.empty())
      log::get("replay")->warn("{}", note);
    if (const auto& ended = replay->nc_output_ended()) {
      // --nc-out cannot be given with --resume: the rest of this run reaches no NC, and says so.
      std::string sinks;
      for (const std::string& s : ended->sinks) sinks += (sinks.empty() ? "" : ", ") + s;
      const std::string from = ended->from_s == storage::kSnapshotBeforeStart_s
                                   ? "its first sample"
                                   : common::shortest_text(std::round((ended->from_s - t0) / 36.0) / 100.0) +
                                         " h of scenario time (its snapshot)";
      std::string before;
      if (ended->not_settled)
        before += "; " + std::to_string(ended->not_settled) +
                  " accepted command(s) before it are not recorded as delivered (not settled: the run stopped before "
                  "their delivery was recorded)";
      if (ended->not_delivered)
        before += "; " + std::to_string(ended->not_delivered) + " accepted command(s) before it were not delivered (the sink failed)";
      log::get("replay")->warn("{}: run {} had NC output ({}); this resume has none (--nc-out cannot be combined with "
                               "--resume): from {} on, no NC command of the run is written or recorded{}",
                               source, *replay->run_id(), sinks, from, before);
    }
    replay->run();
    if (replay->nc() && replay->nc_summary())
      print_nc_summary(source, nc_dir_of(a, name, cases.size() > 1), dialect, *replay->nc(), *replay->nc_summary());
    if (!replay->finished()) {
      // Where it really stopped (the next sample to replay, to 0.01 h): a resume with a --stop-at already
      // passed stops where it resumed.
      const double stopped_h = std::round((scenario.time_s[replay->position()] - t0) / 36.0) / 100.0;
      stopped_at_h[name] = stopped_h;
      std::cerr << source << ": stopped at " << common::shortest_text(stopped_h)
                << " h of scenario time (run " << *replay->run_id() << " in " << a.db
                << "); the indicators below are of that part; continue with --resume\n";
    }
    reports.emplace_back(name, replay->report());
    // CP that never ended (every fit rejected: inputs that do not vary, say): a table of dashes, exit 0
    // (the replay did run); the reason belongs beside it.
    const runtime::ReplayReport& r = reports.back().second;
    const auto rows = static_cast<std::int64_t>(replay->position());
    // The driver of this process saw the samples since the resume only; the count is the whole run's.
    const std::string& first_set_aside = replay->driver().first_rejected_sample();
    const std::string first =
        first_set_aside.empty()
            ? std::string()
            : (plans[k] == ResumePlan::Resume ? "; the first since the resume: " : "; the first: ") + first_set_aside;
    if (!std::isfinite(r.cp_end_s) && replay->finished()) {
      if (r.rejected_samples == rows)
        log::get("replay")->warn("{}: CP never ended: every sample ({}) was set aside, so no model was made and "
                                 "nothing was compensated or evaluated{}",
                                 source, rows, first);
      else if (r.rejected_fits == 0 && r.rejected_samples > 0)
        // No fit was tried: no accepted sample came at or after the end of CP (the rest set aside).
        log::get("replay")->warn("{}: CP never ended: {} of {} samples were set aside and no accepted sample reached "
                                 "the end of CP, so no model was made and nothing was compensated or evaluated{}",
                                 source, r.rejected_samples, rows, first);
      else {
        const std::string& why = replay->driver().last_rejected_fit();
        log::get("replay")->warn("{}: CP never ended: {} fits were rejected, so no model was made and nothing was "
                                 "compensated or evaluated{}",
                                 source, r.rejected_fits, why.empty() ? std::string() : "; the last: " + why);
      }
    }
    if (r.implausible_measurements > 0)
      log::get("replay")->warn("{}: {} recorded measurement(s) after CP beyond the plausible limit (--plausible-lin, "
                               "--plausible-ang) were left out of the indicators; the first: {}",
                               source, r.implausible_measurements, r.first_implausible);
    if (r.rejected_samples > 0 && r.rejected_samples < rows && !(r.rejected_fits == 0 && !std::isfinite(r.cp_end_s)))
      log::get("replay")->warn("{}: {} of {} samples were set aside{}", source, r.rejected_samples, rows, first);
    if (!a.residuals.empty()) scenarios::write_scenario_csv(a.residuals, replay->residuals());
  }
  if (reports.empty()) return;
  // A case stopped before its end says so in its own document and title: its indicators are of a part.
  const auto json_of = [&](const std::string& name, const runtime::ReplayReport& r) {
    nlohmann::json j = runtime::report_json(r);
    if (const auto s = stopped_at_h.find(name); s != stopped_at_h.end()) j["stopped_at_h"] = s->second;
    return j;
  };
  if (a.json) {
    if (reports.size() == 1) {
      std::cout << json_of(reports.front().first, reports.front().second).dump(2) << "\n";
    } else {
      nlohmann::json j = nlohmann::json::object();
      for (const auto& [name, r] : reports) j[name] = json_of(name, r);
      std::cout << j.dump(2) << "\n";
    }
    return;
  }
  for (const auto& [name, r] : reports) {
    const auto s = stopped_at_h.find(name);
    print_report(std::cout,
                 "Load case " + name +
                     (s == stopped_at_h.end() ? "" : " (stopped at " + common::shortest_text(s->second) + " h: a part)"),
                 r);
  }
  if (reports.size() > 1) {
    std::cout << "\n";
    print_table3(std::cout, reports);
  }
}

}  // namespace

void add_replay_command(CLI::App& app) {
  auto args = std::make_shared<ReplayArgs>();
  CLI::App* cmd = app.add_subcommand(
      "replay", "Replay a scenario CSV or built-in load case through the ALC controller and print the indicators "
                "of seed 004 (PV, RMSE, P99, SMAPE per error; Pd, M, NG phases, updates) beside a static MLR "
                "baseline fitted once on the CP measurements. Defaults: the paper's chosen set (Tab. 3).");
  cmd->add_option("file", args->file, "Scenario CSV to replay (see README, 'Scenario CSV')");
  cmd->add_option("--case", args->case_name, "Built-in load case: A, B, C, D, S16, H1-H7, all (A–D with a Tab. 3 summary) or heldout (H1-H5, the same summary)");
  cmd->add_option_function<std::string>(
      "--seed", [args](const std::string& s) { args->seed = parse_seed(s); args->seed_given = true; },
      "Seed of the built-in load case, 0 to 2^64-1 (default: the case's own seed)")
      ->type_name("UINT");
  cmd->add_option("--cp", args->cp, "Calibration phase length [h]")->capture_default_str();
  cmd->add_option("--cp-interval", args->cp_interval, "Probe interval during CP [min]")->capture_default_str();
  cmd->add_option("--interval", args->interval, "Probe interval after CP [h], or inf")->capture_default_str();
  cmd->add_option("--ng-interval", args->ng_interval, "Probe interval in the No-Good phase [min], or inf")
      ->capture_default_str();
  cmd->add_option("--ng-meas", args->ng_meas, "Probes in a No-Good phase before the update, or inf")
      ->capture_default_str();
  cmd->add_option("--update", args->update, "Periodic parameter update interval [h], or inf")->capture_default_str();
  cmd->add_option("--acl-lin", args->acl_lin, "Action control limit of linear errors [µm]")->capture_default_str();
  cmd->add_option("--acl-ang", args->acl_ang, "Action control limit of angular errors [µm/m]")->capture_default_str();
  cmd->add_option("--window", args->window, "Re-identify on the data of the last H hours, or inf (all data)")
      ->capture_default_str();
  cmd->add_option("--since", args->since,
                  "Re-identify only on probes from scenario time H hours on (time_s >= 3600 H), e.g. after a "
                  "repair; the model in use is kept until enough probes exist since then")
      ->type_name("H");
  cmd->add_option("--half-life", args->half_life, "Forgetting: a probe's weight halves every H hours, or inf")
      ->capture_default_str();
  cmd->add_option("--method", args->method, "Identification route: fixed-poles or output-error (docs/identification.md)")
      ->capture_default_str();
  cmd->add_option("--max-order", args->max_order, "Highest number of poles per input tried by structure selection")
      ->capture_default_str();
  cmd->add_option("--structure-refresh", args->structure_refresh,
                  "A probe within the ACL refits the parameters with the structure kept; the structure search is "
                  "redone when the data span has grown by this factor since the last one (1: always, inf: never)")
      ->capture_default_str();
  cmd->add_flag("--no-refit", args->no_refit,
                "The paper's literal loop: re-identify only at the end of CP, after NG and at --update, and every "
                "breach starts a full NG burst (implies --no-confirm); by default every Post-CP probe within the "
                "ACL is learned from too");
  cmd->add_flag("--no-confirm", args->no_confirm,
                "Learn from a breaching probe at once; by default the first NG probe must confirm the breach, and an "
                "unconfirmed one is set aside as an outlier and ends NG");
  cmd->add_option("--schedule", args->schedule,
                  "Post-CP probing: paper (seed 004's fixed interval) or adaptive (probe when the predicted "
                  "uncertainty of the compensated error reaches --uncertainty-fraction x ACL; docs/adaptive.md)")
      ->capture_default_str();
  // The adaptive schedule's and the plausibility limits' options: the help texts of the one option table
  // (runtime/parameter_options.cpp).
  const auto add_table_options = [&](std::initializer_list<std::pair<const char*, std::string*>> options) {
    std::vector<CLI::Option*> added;
    for (const auto& [name, value] : options) {
      const runtime::ParameterOption* o = runtime::find_parameter_option(name);
      const std::string unit = o->unit == "-" ? "" : " [" + std::string(o->unit) + "]";
      added.push_back(cmd->add_option("--" + std::string(name), *value, std::string(o->help) + unit)->capture_default_str());
    }
    return added;
  };
  const auto adaptive_options = add_table_options({{"uncertainty-fraction", &args->uncertainty_fraction},
                                                   {"min-interval", &args->min_interval},
                                                   {"max-interval", &args->max_interval}});
  auto* guard = cmd->add_flag("--guard", args->guard, "The guard, on by default (kept for older command lines)");
  cmd->add_flag("--no-guard", args->no_guard,
                "Compensate with the model's prediction as it is, and probe on the schedule alone. By default a "
                "guard takes a probe as soon as an output's compensation has moved --move-fraction x its ACL since "
                "the last probe, and backs compensation off per "
                "output: it scales the prediction by its least-squares gain in [0, 1] against the errors of the "
                "recent probes and adds the level those probes measured (the decaying mean of what the scaled "
                "prediction left at the recent Post-CP probes, shrunk towards 0), compensates nothing of the model "
                "while the prediction leaves the range of the measured errors (the latest probe's error fading "
                "towards 0 within the bound that follows), keeps compensation within the latest probe's error +- 2 x the fastest drift the "
                "probes measured x the time since, and where the model did worse than none at the first probe "
                "after a fit on a burst of probes compensates that probe's error until the next (docs/adaptive.md)")
      ->excludes(guard);
  const CLI::Option* move_fraction = add_table_options({{"move-fraction", &args->move_fraction}}).front();
  add_table_options({{"plausible-lin", &args->plausible_lin},
                     {"plausible-ang", &args->plausible_ang},
                     {"plausible-temp", &args->plausible_temp},
                     {"plausible-speed", &args->plausible_speed},
                     {"plausible-other", &args->plausible_other}});
  cmd->add_option("--db", args->db,
                  "Record the run in this SQLite history database (created if missing; see 'History database')");
  add_number_option(cmd, "--stop-at", args->stop_at_h,
                    "Stop after H hours of scenario time (from the first sample), save the state and print the "
                    "indicators of the part replayed (needs --db)",
                    0.0, kMaxHours);
  cmd->add_option_function<std::vector<std::string>>(
         "--probe-at",
         [args](const std::vector<std::string>& texts) {
           for (const std::string& text : texts)
             args->probe_at_h.push_back(number_option_value("--probe-at", text, 0.0, kMaxHours));
           std::sort(args->probe_at_h.begin(), args->probe_at_h.end());
           args->probe_at_h.erase(std::unique(args->probe_at_h.begin(), args->probe_at_h.end()), args->probe_at_h.end());
         },
         "Ask for a probe at H hours of scenario time (from the first sample), as someone who knows what no "
         "input shows would: the machine moved, relevelled, repaired, after a collision. Taken at the first "
         "sample at or after H in any phase, an ordinary probe of that phase (after CP a breach starts NG); "
         "a comma-separated list or repeated (docs/adaptive.md, \"Probes asked for\")")
      ->type_name("H[,H...]")
      ->delimiter(',')
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_flag("--resume", args->resume,
                "Continue the latest unfinished run of this scenario in --db from its saved state (found by content "
                "and parameters: another path to the same data is the same run); with several cases, a finished "
                "one is shown from its stored indicators and one never begun begins");
  add_number_option(cmd, "--kill-at", args->kill_at_h,
                    "Fault injection (for tests of crash safety): the process SIGKILLs itself at H hours of scenario "
                    "time, leaving the history as a crash would",
                    0.0, kMaxHours);
  cmd->add_option("--baselines", args->baselines,
                  "The seeds' static models beside ALC, fitted once on the CP measurements and evaluated on the "
                  "same rows: a comma-separated list of mlr, lasso, svr, gm, ols, or all (docs/baselines.md); "
                  "not with --resume")
      ->type_name("LIST");
  cmd->add_flag("--json", args->json, "Print the result as JSON instead of tables");
  cmd->add_option("--residuals", args->residuals,
                  "Write time_s, each measured E_ column and its prediction E_…_pred at every recorded "
                  "measurement after CP to this CSV");
  cmd->add_option("--nc-out", args->nc_out,
                  "Write the NC commands of the replay to this directory: commands.jsonl, program.<ext>, "
                  "safety.jsonl (with --case all one subdirectory per case); the program of another dialect an "
                  "earlier run left there is removed (said on stderr); see 'NC output'");
  cmd->add_option("--dialect", args->dialect, "NC dialect of --nc-out: linuxcnc, fanuc, sinumerik or heidenhain")
      ->capture_default_str();
  cmd->add_option("--machine", args->machine,
                  "Machine config (TOML) for --nc-out and --db: kinematic chain (also of the offsets stored with "
                  "the predictions), NC options, safety limits (default: the built-in A-C chain and limits)");
  cmd->callback([args, adaptive_options, move_fraction] {
    for (const CLI::Option* o : adaptive_options)
      if (o->count() > 0 && args->adaptive_option_given.empty()) args->adaptive_option_given = o->get_name();
    args->move_fraction_given = move_fraction->count() > 0;
    run_replay(*args);
  });
}

}  // namespace alc::cli
