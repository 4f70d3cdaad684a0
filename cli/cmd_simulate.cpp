// alc simulate: write a built-in load case (thermal twin) as a scenario CSV, list the cases, or
// print their figures (duration, peak and P99 of every measured error).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "scenarios/load_cases.hpp"
#include "scenarios/random_processes.hpp"
#include "scenarios/scenario_csv.hpp"
#include "scenarios/scenario_figures.hpp"

namespace alc::cli {
namespace {

namespace sc = alc::scenarios;

struct SimulateArgs {
  std::string case_name;
  std::string out;
  std::string truth;
  std::string seed;  // as given: CLI11 would wrap "-1" to 2^64 - 1 and clamp what is too large
  bool seed_given = false;
  bool list = false;
  bool summary = false;
};

std::string fixed(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  return buffer;
}

std::string case_names() {
  std::string names;
  for (const auto& c : sc::all_cases()) names += (names.empty() ? "" : ", ") + c.name;
  return names + ", all (= A-D) or heldout (= H1-H5)";
}

void print_list() {
  const auto line = [](const sc::LoadCaseInfo& c) {
    std::cout << c.name << "  " << fixed(c.duration_h, 0) << " h  every " << fixed(c.step_s, 0) << " s  seed "
              << c.default_seed << "  " << c.description << "\n";
  };
  std::cout << "load cases (C-axis twin):\n";
  for (const auto& c : sc::load_cases()) line(c);
  std::cout << "recording-like scenarios:\n";
  for (const auto& c : sc::recording_cases()) line(c);
  std::cout << "held-out variants of the C-axis twin (heldout):\n";
  for (const auto& c : sc::heldout_cases()) line(c);
  std::cout << "held-out, built after the adaptive policy was settled (by name only):\n";
  for (const auto& c : sc::later_heldout_cases()) line(c);
}

// The noiseless truth as a scenario CSV: true loads and node temperatures as inputs, the true
// errors at every sample as outputs.
sc::Scenario truth_scenario(const sc::SimulatedCase& run) {
  sc::Scenario s;
  s.input_names = {"ambient", "speed", "fluid_on"};
  for (const auto& node : run.truth.node_names) s.input_names.push_back("node_" + node);
  s.output_names = run.truth.error_names;
  s.time_s = run.profile.time_s;
  const auto n = static_cast<Eigen::Index>(s.time_s.size());
  s.inputs.resize(n, static_cast<Eigen::Index>(s.input_names.size()));
  for (Eigen::Index r = 0; r < n; ++r) {
    const auto& load = run.profile.loads[static_cast<std::size_t>(r)];
    s.inputs(r, 0) = sc::quantise(load.ambient_C, 0.001);
    s.inputs(r, 1) = load.speed_rpm;
    s.inputs(r, 2) = load.fluid_on ? 1.0 : 0.0;
    for (Eigen::Index j = 0; j < run.truth.nodes.cols(); ++j) s.inputs(r, 3 + j) = sc::quantise(run.truth.nodes(r, j), 0.001);
  }
  s.outputs = run.truth.errors.unaryExpr([](double v) { return sc::quantise(v, 0.001); });
  return s;
}

// One Markdown table per group of consecutive cases with the same errors.
void print_summary(const std::vector<sc::SimulatedCase>& runs) {
  std::vector<std::string> header_of_table;
  for (const sc::SimulatedCase& run : runs) {
    const sc::ScenarioFigures f = sc::scenario_figures(run.scenario);
    if (run.scenario.output_names != header_of_table) {
      if (!header_of_table.empty()) std::cout << "\n";
      header_of_table = run.scenario.output_names;
      std::cout << "| case | seed | duration [h] | samples | probes |";
      for (const auto& e : f.errors) std::cout << " " << e.name << " peak / P99 [" << (e.angular ? "µm/m" : "µm") << "] |";
      std::cout << "\n|---|---|---|---|---|";
      for (std::size_t i = 0; i < f.errors.size(); ++i) std::cout << "---|";
      std::cout << "\n";
    }
    const int probes = f.errors.empty() ? 0 : f.errors.front().measurements;
    std::cout << "| " << run.info.name << " | " << run.seed << " | " << fixed(f.duration_h, 1) << " | " << f.samples
              << " | " << probes << " |";
    for (const auto& e : f.errors) std::cout << " " << fixed(e.peak, 1) << " / " << fixed(e.p99, 1) << " |";
    std::cout << "\n";
  }
}

void run_simulate(const SimulateArgs& args) {
  if (args.list) {
    print_list();
    return;
  }
  if (args.case_name.empty()) throw UsageError("simulate: give --case NAME (" + case_names() + "), or --list");
  std::vector<std::string> names;
  if (args.case_name == "all" || args.case_name == "heldout") {
    if (!args.out.empty() || !args.truth.empty())
      throw UsageError("simulate: --out and --truth write one case; with --case " + args.case_name + " use --summary");
    names = load_case_names(args.case_name);
  } else {
    if (!sc::find_case(args.case_name))
      throw UsageError("simulate: unknown --case '" + args.case_name + "' (expected " + case_names() + ")");
    names.push_back(args.case_name);
  }
  if (args.out.empty() && args.truth.empty() && !args.summary)
    throw UsageError("simulate: nothing to do; give --out FILE, --truth FILE or --summary");

  std::optional<std::uint64_t> seed;
  if (args.seed_given) seed = parse_seed(args.seed);
  // Both targets judged before either is written: a failed command leaves nothing half done, and
  // --truth onto --out would replace the scenario with the truth.
  refuse_output_over_input("--truth", args.truth, args.out, "the --out file");
  for (const auto& [option, target] : {std::pair{"--out", &args.out}, std::pair{"--truth", &args.truth}})
    refuse_unwritable_output(option, *target);

  std::vector<sc::SimulatedCase> runs;
  for (const auto& name : names) {
    runs.push_back(sc::simulate_case(name, seed));
    if (!args.out.empty()) sc::write_scenario_csv(args.out, runs.back().scenario);
    if (!args.truth.empty()) sc::write_scenario_csv(args.truth, truth_scenario(runs.back()));
  }
  if (args.summary) print_summary(runs);
  std::cout.flush();
  if (!std::cout) throw std::runtime_error("cannot write to stdout");
}

}  // namespace

void add_simulate_command(CLI::App& app) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "simulate",
      "Simulate a built-in load case on the thermal twin and write it as a scenario CSV: sensor inputs at every "
      "sample and probe measurements of the errors (empty cells between probes). See docs/twin.md.");
  cmd->add_option("--case", args->case_name,
                  "Case to simulate: A, B, C, D (C-axis load cases, 8 days at 1 min), S16 (recording-like spindle run), "
                  "H1-H7 (held-out variants of the C-axis twin), all (A-D) or heldout (H1-H5), the last two with --summary");
  cmd->add_option("--out", args->out, "Write the scenario CSV (what sensors and the probe gave) to this file");
  cmd->add_option("--truth", args->truth,
                  "Also write the noiseless truth (loads, node temperatures, true errors at every sample) as CSV");
  CLI::Option* seed = cmd->add_option("--seed", args->seed,
                                      "Seed of every random draw, 0 to 2^64-1 (default: the case's own seed; same seed, "
                                      "same file)")
                          ->type_name("UINT");
  CLI::Option* list = cmd->add_flag("--list", args->list, "List the cases: name, duration, sampling, seed, description");
  cmd->add_flag("--summary", args->summary,
                "Print each case's duration and the peak and P99 of |measured error| per error (Markdown table)");
  list->excludes("--case")->excludes("--out")->excludes("--truth")->excludes("--summary")->excludes(seed);
  cmd->callback([args, seed]() {
    args->seed_given = seed->count() > 0;
    run_simulate(*args);
  });
}

}  // namespace alc::cli
