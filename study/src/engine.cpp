#include "study/engine.hpp"

#include <algorithm>
#include <map>
#include <mutex>
#include <thread>

#include "runtime/driver.hpp"
#include "runtime/recorded_source.hpp"
#include "runtime/replay.hpp"

namespace alc::study {

namespace {

// The options of `set` whose stage is in [first, last], as one key.
std::string stage_key(const ParameterSet& set, runtime::Stage first, runtime::Stage last) {
  std::string key;
  for (const auto& [name, value] : set.options) {
    const runtime::ParameterOption* o = runtime::find_parameter_option(name);
    if (o && o->stage >= first && o->stage <= last) key += name + "=" + value + " ";
  }
  return key;
}

// The fit summary's condition numbers and standard errors: no decision reads them and no row shows them.
AlcParameters without_statistics(AlcParameters p) {
  p.identification.fit_statistics = false;
  return p;
}

// One controller of a unit with what a replay drives beside it: the source at its row, the
// indicators, the driver loop.
struct Branch {
  Controller controller;
  runtime::RecordedSource source;
  runtime::Evaluation evaluation;
  runtime::Driver driver;

  Branch(const scenarios::Scenario& s, const AlcParameters& p)
      : controller(s.input_names, s.output_names, without_statistics(p)), source(s), evaluation(s), driver(controller) {
    driver.add(evaluation);
  }
  // A copy of `o` that continues with `p` (Controller::fork).
  Branch(const Branch& o, const AlcParameters& p)
      : controller(o.controller.fork(without_statistics(p))), source(o.source), evaluation(o.evaluation), driver(controller) {
    driver.add(evaluation);
    if (o.driver.last_sample()) driver.continue_after(*o.driver.last_sample());
  }
  Branch(const Branch&) = delete;
};

struct Stopped {};

class UnitRunner {
 public:
  UnitRunner(std::size_t case_index, const std::vector<ParameterSet>& sets, const StudyOptions& options,
             StudyStats& stats)
      : case_index_(case_index), sets_(sets), options_(options), stats_(stats) {}

  // Runs `members` from the branch's position (after `pending`, a probe it still has to take).
  void run(Branch& b, const std::vector<std::size_t>& members, const ProbeMeasurement* pending,
           std::vector<StudyRow>& rows) {
    if (pending) {
      count(b.driver.probe(*pending));
      b.driver.sample_done();
    }
    std::map<std::string, std::vector<std::size_t>> by_key;
    std::vector<std::string> key_order;
    if (options_.share) {
      for (const std::size_t m : members) {
        const std::string k = stage_key(sets_[m], runtime::Stage::Breach, runtime::Stage::Breach);
        if (by_key.find(k) == by_key.end()) key_order.push_back(k);
        by_key[k].push_back(m);
      }
    }
    const bool may_fork = key_order.size() > 1;
    while (auto s = b.source.next(kInf)) {
      if (options_.stop && (++polls_ & 1023) == 0 && options_.stop->load()) throw Stopped{};
      ++stats_.samples;
      const ControllerOutput out = b.driver.sample(*s);
      count(out);
      if (!out.accepted) continue;
      if (auto p = b.source.probe(b.controller.state().next_probe_due_s, *s)) {
        if (may_fork && b.controller.phase() == Phase::PostCalibration && b.controller.breaches_acl(*p)) {
          // The first breach after CP: here the Breach options first matter.
          for (std::size_t g = 0; g + 1 < key_order.size(); ++g) {
            const auto& group = by_key[key_order[g]];
            Branch child(b, sets_[group.front()].parameters);
            ++stats_.forks;
            run(child, group, &*p, rows);
          }
          const auto& last = by_key[key_order.back()];
          b.controller = std::move(b.controller).fork(without_statistics(sets_[last.front()].parameters));
          ++stats_.forks;
          run(b, last, &*p, rows);
          return;
        }
        count(b.driver.probe(*p));
      }
      b.driver.sample_done();
    }
    const runtime::ReplayReport report = b.evaluation.report(b.controller, b.source.position());
    ++stats_.runs;
    for (const std::size_t m : members) rows.push_back({m, case_index_, {}, report});
  }

 private:
  void count(const ControllerOutput& out) {
    if (out.fit) ++stats_.fits;
  }
  std::size_t case_index_;
  const std::vector<ParameterSet>& sets_;
  const StudyOptions& options_;
  StudyStats& stats_;
  unsigned polls_ = 0;
};

}  // namespace

// Why a valid set cannot run on a case (alc replay refuses it: a CP longer than the recording, a since
// after its end...): an error row, not a run that never leaves CP and reads as status ok.
std::string run_problem(const StudyCase& c, const ParameterSet& set) {
  return runtime::scenario_problem(c.scenario, set.parameters, c.source, {"cp =", "", "since =", ""});
}

std::vector<Unit> plan_units(const std::vector<StudyCase>& cases, const std::vector<ParameterSet>& sets) {
  std::vector<Unit> units;
  for (std::size_t c = 0; c < cases.size(); ++c) {
    std::map<std::string, std::size_t> unit_of;
    for (const ParameterSet& s : sets) {
      if (!s.error.empty() || !run_problem(cases[c], s).empty()) continue;
      const std::string key = stage_key(s, runtime::Stage::Start, runtime::Stage::CpEnd);
      const auto [it, added] = unit_of.emplace(key, units.size());
      if (added) units.push_back({c, {}});
      units[it->second].sets.push_back(s.index);
    }
  }
  return units;
}

bool unit_in_shard(std::size_t unit_index, int shard, int shards) {
  return static_cast<int>(unit_index % static_cast<std::size_t>(shards)) == shard - 1;
}

bool invalid_set_in_shard(std::size_t set_index, int shard, int shards) {
  return static_cast<int>(set_index % static_cast<std::size_t>(shards)) == shard - 1;
}

std::size_t shard_rows(const std::vector<StudyCase>& cases, const std::vector<ParameterSet>& sets, int shard,
                       int shards) {
  std::size_t rows = 0;
  const std::vector<Unit> units = plan_units(cases, sets);
  for (std::size_t u = 0; u < units.size(); ++u)
    if (unit_in_shard(u, shard, shards)) rows += units[u].sets.size();
  for (const ParameterSet& s : sets) {
    if (!invalid_set_in_shard(s.index, shard, shards)) continue;
    if (!s.error.empty()) {
      rows += cases.size();
      continue;
    }
    for (const StudyCase& c : cases) rows += run_problem(c, s).empty() ? 0 : 1;
  }
  return rows;
}

StudyStats run_study(const std::vector<StudyCase>& cases, const std::vector<ParameterSet>& sets,
                     const StudyOptions& options) {
  StudyStats total;
  std::mutex mutex;
  const auto wanted = [&](std::size_t set, std::size_t c) { return !options.wanted || options.wanted(set, c); };
  const auto deliver = [&](std::vector<StudyRow>&& rows, const StudyStats& stats) {
    std::lock_guard<std::mutex> lock(mutex);
    total.rows += rows.size();
    total.runs += stats.runs;
    total.forks += stats.forks;
    total.samples += stats.samples;
    total.fits += stats.fits;
    // Only rows that ran: an error row (an invalid set, a set the case cannot run) costs nothing either way.
    for (const StudyRow& r : rows)
      if (r.report) total.samples_alone += static_cast<std::int64_t>(cases[r.case_index].scenario.samples());
    if (!rows.empty() && options.on_rows) options.on_rows(std::move(rows));
  };

  // Invalid sets, and valid ones a case cannot run: a row with the error per case, no run.
  std::vector<StudyRow> invalid;
  for (const ParameterSet& s : sets)
    if (invalid_set_in_shard(s.index, options.shard, options.shards))
      for (std::size_t c = 0; c < cases.size(); ++c) {
        const std::string why = s.error.empty() ? run_problem(cases[c], s) : s.error;
        if (!why.empty() && wanted(s.index, c)) invalid.push_back({s.index, c, why, std::nullopt});
      }
  deliver(std::move(invalid), StudyStats{});

  // Units of this shard, with the members still wanted; without sharing every set is its own unit.
  std::vector<Unit> units;
  const std::vector<Unit> plan = plan_units(cases, sets);
  for (std::size_t u = 0; u < plan.size(); ++u) {
    if (!unit_in_shard(u, options.shard, options.shards)) continue;
    Unit unit{plan[u].case_index, {}};
    for (const std::size_t s : plan[u].sets)
      if (wanted(s, unit.case_index)) unit.sets.push_back(s);
    if (unit.sets.empty()) continue;
    if (options.share) {
      units.push_back(std::move(unit));
    } else {
      for (const std::size_t s : unit.sets) units.push_back({unit.case_index, {s}});
    }
  }
  total.units = units.size();

  std::atomic<std::size_t> next{0};
  std::atomic<bool> stopped{false};
  const auto worker = [&] {
    while (true) {
      if (options.stop && options.stop->load()) {
        stopped = true;
        return;
      }
      const std::size_t u = next++;
      if (u >= units.size()) return;
      const Unit& unit = units[u];
      const StudyCase& c = cases[unit.case_index];
      StudyStats stats;
      std::vector<StudyRow> rows;
      try {
        Branch trunk(c.scenario, sets[unit.sets.front()].parameters);
        UnitRunner(unit.case_index, sets, options, stats).run(trunk, unit.sets, nullptr, rows);
      } catch (const Stopped&) {
        stopped = true;
        return;
      } catch (const std::exception& e) {
        // The members without a row yet fail with the reason; the rows of finished branches stay.
        for (const std::size_t s : unit.sets)
          if (std::none_of(rows.begin(), rows.end(), [&](const StudyRow& r) { return r.set == s; }))
            rows.push_back({s, unit.case_index, std::string("run failed: ") + e.what(), std::nullopt});
      }
      std::sort(rows.begin(), rows.end(), [](const StudyRow& a, const StudyRow& b) { return a.set < b.set; });
      deliver(std::move(rows), stats);
    }
  };
  const int jobs = std::max(1, std::min<int>(options.jobs, static_cast<int>(std::max<std::size_t>(units.size(), 1))));
  std::vector<std::thread> threads;
  for (int j = 1; j < jobs; ++j) threads.emplace_back(worker);
  worker();
  for (auto& t : threads) t.join();
  total.stopped = stopped;
  return total;
}

}  // namespace alc::study
