// alc study: a parameter study over a grid of controller parameters (docs/study.md); merge of shards;
// report of a study file.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <mutex>
#include <random>
#include <thread>
#include <tuple>

#include "alc_version.hpp"
#include "commands.hpp"
#include "common/atomic_file.hpp"
#include "common/log.hpp"
#include "common/number_text.hpp"
#include "runtime/parameter_options.hpp"
#include "runtime/replay.hpp"
#include "runtime/report_json.hpp"
#include "scenarios/load_cases.hpp"
#include "scenarios/scenario_csv.hpp"
#include "storage/storage_error.hpp"
#include "study/analysis.hpp"
#include "study/figures.hpp"

namespace alc::cli {

namespace {

namespace fs = std::filesystem;

std::atomic<bool> g_stop{false};
std::atomic<int> g_signal{0};
void on_signal(int sig) {
  g_signal = sig;
  g_stop = true;
}

// SIGINT and SIGTERM go to on_signal while it lives; the handlers before are back when it ends
// (also when the study throws).
class StopSignals {
 public:
  StopSignals() {
    struct sigaction sa {};
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~StopSignals() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  struct sigaction old_int_ {}, old_term_ {};
};

struct StudyArgs {
  std::string grid;
  std::string case_name;
  std::vector<std::string> files;
  int jobs = 0;                 // 0: every core
  std::string db, csv;
  bool json = false;
  std::string shard;            // "I/N"
  bool resume = false;
  bool bench = false;
  int bench_sample = 200;
  std::uint64_t bench_seed = 1;
  bool quiet = false;
};

struct MergeArgs {
  std::string out;
  std::vector<std::string> shards;
};

struct ReportArgs {
  std::string file;
  bool json = false;
  std::string csv;
  double limit = 5.0;
  std::string svg;              // directory for the figures
  std::string heatmap_cp;       // CP of the heat maps ("" : the default)
};

std::string version() { return std::string("alc ") + ALC_VERSION; }

// "I/N" with 1 <= I <= N, decimal digits only (common::parse_whole_number).
std::pair<int, int> parse_shard(const std::string& text) {
  const auto slash = text.find('/');
  if (slash != std::string::npos) {
    try {
      const auto n = common::parse_whole_number("--shard", text.substr(slash + 1), 1, 999999);
      const auto i = common::parse_whole_number("--shard", text.substr(0, slash), 1, n);
      return {static_cast<int>(i), static_cast<int>(n)};
    } catch (const std::invalid_argument&) {
    }
  }
  throw UsageError("--shard: '" + text + "' is not I/N with 1 <= I <= N (e.g. 3/8)");
}

std::vector<study::StudyCase> load_cases(const StudyArgs& a) {
  if (a.case_name.empty() == a.files.empty()) throw UsageError("give --case or scenario CSV files (not both)");
  std::vector<study::StudyCase> cases;
  if (!a.case_name.empty()) {
    for (const std::string& name : load_case_names(a.case_name)) {
      auto sim = scenarios::simulate_case(name, std::nullopt);
      cases.push_back({name, "case " + name, std::move(sim.scenario), {}});
    }
  } else {
    for (const std::string& f : a.files) {
      std::error_code ec;
      if (fs::is_directory(f, ec)) throw UsageError(f + ": is a directory, not a scenario CSV");
      // A case is named by its path as given, written plainly (./a.csv and a.csv are one name, as alc
      // replay has it): the same file twice would be two cases of one name (and one row of each set
      // counted twice in every mean). Reached by another path (absolute, a link) or copied, it is the
      // same recording: its content says so.
      const std::string name = fs::path(f).lexically_normal().string();
      for (const auto& c : cases)
        if (c.name == name) throw UsageError(f + ": given twice (a case is named by its file)");
      study::StudyCase added{name, "file " + name, scenarios::read_scenario_csv(f), {}};
      added.content_hash = study::content_hash(added.scenario);
      for (const auto& c : cases)
        if (c.content_hash == added.content_hash)
          throw UsageError(f + ": the same recording as " + c.name + " (content hash " + c.content_hash +
                           "): it would count twice in every mean");
      cases.push_back(std::move(added));
    }
  }
  for (auto& c : cases)
    if (c.content_hash.empty()) c.content_hash = study::content_hash(c.scenario);
  return cases;
}

// Progress on stderr: a bar on a terminal (redrawn every 0.2 s), a plain line every 5 s otherwise, from
// a thread of its own: a unit of many sets sharing one trunk gives its rows only at its end, and a
// large grid's first unit may take a minute.
class Progress {
 public:
  Progress(std::size_t total, std::size_t reused, bool quiet)
      : total_(total), done_(reused), reused_(reused), quiet_(quiet), tty_(::isatty(STDERR_FILENO) != 0),
        start_(std::chrono::steady_clock::now()) {
    if (quiet_) return;
    if (!tty_) draw(false);  // at once: what is to come
    ticker_ = std::thread([this] {
      const auto period = std::chrono::milliseconds(tty_ ? 200 : 5000);
      std::unique_lock<std::mutex> lock(mutex_);
      while (!stopping_)
        if (!wake_.wait_for(lock, period, [this] { return stopping_; })) draw(false);
    });
  }
  ~Progress() { stop(); }
  void add(std::size_t rows) { done_ += rows; }
  void finish() {
    stop();
    if (!quiet_ && tty_) draw(true);
  }
  double elapsed() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

 private:
  void stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    if (ticker_.joinable()) ticker_.join();
  }
  void draw(bool last) {
    const double t = elapsed();
    const std::size_t done = done_.load();
    const double rate = t > 0 ? static_cast<double>(done - reused_) / t : 0.0;
    char eta[32] = "-";  // no run done yet: no rate to go by
    if (rate > 0) std::snprintf(eta, sizeof eta, "%.0f s", static_cast<double>(total_ - done) / rate);
    char line[192];
    if (tty_) {
      const int width = 30;
      const int filled = total_ ? static_cast<int>(width * static_cast<double>(done) / static_cast<double>(total_)) : width;
      std::string bar(static_cast<std::size_t>(filled), '#');
      bar.resize(width, '.');
      std::snprintf(line, sizeof line, "\r[%s] %zu/%zu runs  %.0f runs/s  ETA %s ", bar.c_str(), done, total_, rate,
                    eta);
      std::cerr << line << (last ? "\n" : "") << std::flush;
    } else {
      std::snprintf(line, sizeof line, "study: %zu/%zu runs, %.0f runs/s, ETA %s, %.0f s in\n", done, total_, rate,
                    eta, t);
      std::cerr << line << std::flush;
    }
  }
  std::size_t total_;
  std::atomic<std::size_t> done_;
  std::size_t reused_;
  bool quiet_, tty_;
  std::chrono::steady_clock::time_point start_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread ticker_;
};

std::vector<storage::StudyRowRecord> sorted(std::vector<storage::StudyRowRecord> rows) {
  std::sort(rows.begin(), rows.end(), [](const auto& x, const auto& y) {
    return std::tie(x.set_index, x.case_index) < std::tie(y.set_index, y.case_index);
  });
  return rows;
}

// --csv -: the rows on stdout (a pipe gets the CSV alone) and the analysis on stderr.
constexpr const char* kStdout = "-";

void write_csv(const std::string& file, const study::StudyInfo& info, const std::vector<storage::StudyRowRecord>& rows) {
  if (file == kStdout) {
    study::write_rows_csv(std::cout, info, rows);
    std::cout.flush();
    return;
  }
  io::write_file_atomically(file, [&](std::ostream& os) { study::write_rows_csv(os, info, rows); });
}

// Before anything is computed: --csv - and --json cannot share stdout; a file must be writable.
void check_csv_option(const std::string& csv, bool json) {
  if (csv == kStdout && json) throw UsageError("--csv - and --json both write to stdout: give --csv a file");
  // Exit 1 as every output that cannot be written (README: "refused (exit 1)"), not a usage error.
  if (csv != kStdout) refuse_unwritable_output("--csv", csv);
}

void print_analysis(const study::Analysis& analysis, const study::StudyInfo& info, bool json, const std::string& csv) {
  std::ostream& out = csv == kStdout ? std::cerr : std::cout;
  if (json) out << study::analysis_json(analysis, info).dump(2) << "\n";
  else study::print_analysis(out, analysis, info);
}

// The benchmark: the grid with shared work, then a seeded random sample of its runs as independent
// replays in the same invocation; the ratio of the time per run.
void run_bench(const StudyArgs& a, const study::StudyInfo& info, const std::vector<study::StudyCase>& cases, int jobs) {
  std::vector<storage::StudyRowRecord> rows;
  study::StudyOptions o;
  o.jobs = jobs;
  o.on_rows = [&](std::vector<study::StudyRow>&& r) {
    for (const auto& row : r) rows.push_back(study::record_of(row));
  };
  const auto t0 = std::chrono::steady_clock::now();
  const study::StudyStats st = study::run_study(cases, info.sets, o);
  const double shared_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double rss_mb = proc_status_kb("VmHWM") / 1024.0;
  // The sample: distinct (set, case) of the rows that ran (not an invalid set, nor one the case cannot
  // run: replay would refuse those), in the grid's order, drawn with the seed.
  std::vector<std::pair<std::size_t, std::size_t>> pool;
  for (const auto& r : rows)
    if (r.ok) pool.emplace_back(static_cast<std::size_t>(r.set_index), static_cast<std::size_t>(r.case_index));
  std::sort(pool.begin(), pool.end());
  std::mt19937_64 rng(a.bench_seed);
  std::shuffle(pool.begin(), pool.end(), rng);
  pool.resize(std::min<std::size_t>(pool.size(), static_cast<std::size_t>(a.bench_sample)));
  std::map<std::pair<std::size_t, std::size_t>, std::string> alone;
  std::mutex mutex;
  std::atomic<std::size_t> next{0};
  const auto t1 = std::chrono::steady_clock::now();
  const auto worker = [&] {
    for (std::size_t i = next++; i < pool.size(); i = next++) {
      const auto [set, c] = pool[i];
      const std::string j = runtime::report_json(runtime::replay(cases[c].scenario, info.sets[set].parameters)).dump();
      std::lock_guard<std::mutex> lock(mutex);
      alone[pool[i]] = j;
    }
  };
  std::vector<std::thread> threads;
  for (int j = 1; j < jobs; ++j) threads.emplace_back(worker);
  worker();
  for (auto& t : threads) t.join();
  const double alone_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  std::size_t same = 0;
  for (const auto& r : rows) {
    const auto it = alone.find({static_cast<std::size_t>(r.set_index), static_cast<std::size_t>(r.case_index)});
    if (it != alone.end() && it->second == r.report_json) ++same;
  }
  const double per_run_shared = shared_s / static_cast<double>(st.rows);
  const double per_run_alone = alone_s / static_cast<double>(pool.size());
  std::printf("study benchmark: grid %s, %zu sets x %zu cases = %zu runs, %d jobs\n", a.grid.c_str(), info.sets.size(),
              cases.size(), st.rows, jobs);
  std::printf("  shared work:   %.1f s wall, %.1f runs/s, %zu controller runs (%zu forks, %zu units), peak RSS %.0f MB\n",
              shared_s, static_cast<double>(st.rows) / shared_s, st.runs, st.forks, st.units, rss_mb);
  std::printf("  work saved by sharing: %.1f %% of the sample cycles (%lld of %lld executed), %lld identifications\n",
              100.0 * (1.0 - static_cast<double>(st.samples) / static_cast<double>(st.samples_alone)),
              static_cast<long long>(st.samples), static_cast<long long>(st.samples_alone), static_cast<long long>(st.fits));
  std::printf("  independent replays (baseline, seed %llu): %zu random runs in %.1f s, %.1f runs/s; "
              "identical to the study's rows: %zu of %zu\n",
              static_cast<unsigned long long>(a.bench_seed), pool.size(), alone_s,
              static_cast<double>(pool.size()) / alone_s, same, pool.size());
  std::printf("  ratio: %.1f x faster per run than independent replays (all %zu runs alone: ~%.0f s)\n",
              per_run_alone / per_run_shared, st.rows, per_run_alone * static_cast<double>(st.rows));
  if (same != pool.size()) throw std::runtime_error("benchmark: shared rows differ from independent replays");
}

void run_study_command(const StudyArgs& a) {
  if (a.grid.empty()) throw UsageError("--grid is required (paper or a TOML file)");
  study::StudyInfo info;
  try {
    info.grid = study::load_grid(a.grid);
  } catch (const study::GridError& e) {
    throw UsageError(std::string("--grid: ") + e.what());
  }
  info.sets = info.grid.sets();
  const std::vector<study::StudyCase> cases = load_cases(a);
  info.cases = study::case_infos(cases);
  info.software_version = version();
  int shard = 1, shards = 1;
  if (!a.shard.empty()) {
    std::tie(shard, shards) = parse_shard(a.shard);
    info.shard = a.shard;
  }
  if (a.jobs < 0) throw UsageError("--jobs: must be >= 1 (0: every core)");
  const int jobs = a.jobs > 0 ? a.jobs : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  if (a.bench) {
    if (!a.db.empty() || a.resume || !a.shard.empty() || !a.csv.empty())
      throw UsageError("--bench takes no --db, --csv, --shard or --resume");
    run_bench(a, info, cases, jobs);
    return;
  }
  if (a.resume && a.db.empty()) throw UsageError("--resume needs --db");
  // Before the rows are computed, not after (hours of work, lost without --db).
  check_csv_option(a.csv, a.json);
  refuse_output_over_input("--csv", a.csv, a.db, "the study database");
  for (const std::string& f : a.files) refuse_output_over_input("--csv", a.csv, f, "a recording the study reads");
  if (a.grid != "paper") refuse_output_over_input("--csv", a.csv, a.grid, "the grid file");

  std::vector<storage::StudyRowRecord> rows;
  std::unique_ptr<storage::StudyStore> store;
  std::set<std::pair<std::int64_t, std::int64_t>> done;
  if (!a.db.empty()) {
    std::error_code ec;
    if (fs::is_directory(a.db, ec)) throw UsageError("--db: " + a.db + " is a directory");
    const auto stored = storage::StudyStore::header_of(a.db);
    storage::StudyHeader now = info.header();
    if (stored && !a.resume)
      throw UsageError(a.db + " holds a study already: continue it with --resume, or give another --db");
    // The empty file of a run killed before its first row (a requeued SLURM task resumes it): begin.
    const bool empty = !stored && storage::StudyStore::holds_nothing(a.db);
    if (!stored && a.resume && !empty) throw UsageError(a.db + " holds no study to resume");
    if (stored) {
      const std::string diff = study::difference(*stored, now);
      if (!diff.empty()) throw UsageError("cannot resume the study in " + a.db + ": " + diff);
      // A recording reached by another path is the stored case: its stored name stays the study's.
      for (const std::string& r : study::renamed_cases(*stored, now))
        log::get("study")->warn("{}: the same recording (content) as the study's case, continued under its stored name ({})",
                                a.db, r);
      now.cases_json = stored->cases_json;
      info.cases = study::cases_of(stored->cases_json);  // the grid is the same: not expanded again
      rows = storage::StudyStore::rows_of(a.db);
    }
    store = std::make_unique<storage::StudyStore>(
        a.db, now, stored ? storage::StudyStore::Existing::Continue : storage::StudyStore::Existing::Refuse);
    for (const auto& r : rows) done.emplace(r.set_index, r.case_index);
  }
  // A recording measured more sparsely than a set's schedule, as alc replay tells it: once per case, for
  // the first set it concerns, with how many sets it concerns (the notes depend on three parameters only).
  for (const study::StudyCase& c : cases) {
    std::map<std::tuple<double, double, double>, std::string> notes;
    std::size_t concerned = 0;
    std::string first;
    for (const study::ParameterSet& set : info.sets) {
      if (!set.error.empty()) continue;
      const AlcParameters& p = set.parameters;
      const auto key = std::make_tuple(p.cp_duration_s, p.cp_interval_s, p.ng_interval_s);
      auto it = notes.find(key);
      if (it == notes.end()) it = notes.emplace(key, runtime::sparse_measurements(c.scenario, p, c.source)).first;
      if (it->second.empty()) continue;
      if (concerned++ == 0) first = it->second + " (set " + set.key + ")";
    }
    if (concerned > 0)
      log::get("study")->warn("{}; {} of the {} sets are concerned", first, concerned, info.sets.size());
  }
  const std::size_t total = study::shard_rows(cases, info.sets, shard, shards);  // this shard's rows
  const std::size_t reused = done.size();
  Progress progress(total, reused, a.quiet);
  study::StudyOptions o;
  o.jobs = jobs;
  o.shard = shard;
  o.shards = shards;
  o.stop = &g_stop;
  o.wanted = [&](std::size_t set, std::size_t c) {
    return done.find({static_cast<std::int64_t>(set), static_cast<std::int64_t>(c)}) == done.end();
  };
  o.on_rows = [&](std::vector<study::StudyRow>&& r) {
    std::vector<storage::StudyRowRecord> records;
    for (const auto& row : r) records.push_back(study::record_of(row));
    if (store) store->add(records);
    rows.insert(rows.end(), records.begin(), records.end());
    progress.add(records.size());
  };
  g_stop = false;
  g_signal = 0;
  study::StudyStats st;
  {
    const StopSignals signals;
    // The runs of thousands of sets would repeat their case's warnings once per set: each text once.
    log::distinct_only(true);
    struct Restore {
      ~Restore() { log::distinct_only(false); }
    } restore;
    st = study::run_study(cases, info.sets, o);
    progress.finish();
    if (const std::size_t repeats = log::repeats_withheld(); repeats > 0)
      std::cerr << "study: " << repeats << " log line(s) of the runs repeated an earlier one and were not shown\n";
  }
  const std::size_t computed = rows.size() - reused;
  if (st.stopped || g_stop) {
    const int sig = g_signal.load();
    throw ExitStatus(128 + (sig ? sig : SIGINT),
                     "study stopped by signal " + std::to_string(sig) + ": " + std::to_string(rows.size()) + " of " +
                         std::to_string(total) + " rows done (" + std::to_string(computed) + " computed now)" +
                         (store ? "; continue with --resume --db " + a.db : "; nothing kept (no --db)"));
  }
  if (a.resume) std::cerr << "resumed " << a.db << ": " << reused << " rows reused, " << computed << " computed\n";
  rows = sorted(std::move(rows));
  if (!a.csv.empty()) write_csv(a.csv, info, rows);
  print_analysis(study::analyse(info, rows, 5.0), info, a.json, a.csv);
  if (!a.json && !a.quiet)
    std::cerr << "study: " << rows.size() << " rows in " << common::shortest_text(std::round(progress.elapsed() * 10.0) / 10.0)
              << " s (" << st.runs << (st.runs == 1 ? " controller run, " : " controller runs, ") << st.forks
              << (st.forks == 1 ? " fork)\n" : " forks)\n");
}

void run_merge(const MergeArgs& a) {
  if (a.shards.empty()) throw UsageError("study merge: give the shard files");
  if (a.out == "-") throw UsageError("--out is the merged study file: '-' (stdout) is not offered");
  std::optional<storage::StudyHeader> first;
  std::vector<storage::StudyRowRecord> rows;
  std::map<std::pair<std::int64_t, std::int64_t>, std::string> owner;
  std::set<std::string> shard_names;
  for (const std::string& f : a.shards) {
    if (std::error_code missing; !fs::exists(f, missing)) throw UsageError(f + ": no such file");
    const auto h = storage::StudyStore::header_of(f);
    if (!h) throw UsageError(f + ": holds no study");
    storage::StudyHeader as_all = *h;
    as_all.shard = "all";
    if (!first) {
      first = as_all;
    } else if (const std::string d = study::difference(*first, as_all); !d.empty()) {
      throw UsageError(f + " is not a shard of the study in " + a.shards.front() + ": " + d);
    } else {
      for (const std::string& r : study::renamed_cases(*first, as_all))
        log::get("study")->warn("{}: the same recording (content) as a case of {}, merged under that name ({})", f,
                                a.shards.front(), r);
    }
    if (!shard_names.insert(h->shard).second) throw UsageError(f + ": shard " + h->shard + " is given twice");
    // Shards of one split only: 1/3 with 2/2 overlap or leave gaps by construction.
    const auto split_of = [](const std::string& shard) { return shard.substr(shard.find('/') + 1); };
    if (split_of(h->shard) != split_of(*shard_names.begin()))
      throw UsageError(f + ": shard " + h->shard + " is of another split than shard " + *shard_names.begin() +
                       " (every shard of a merge must be I/N with the same N)");
    for (auto& r : storage::StudyStore::rows_of(f)) {
      const auto [it, added] = owner.emplace(std::make_pair(r.set_index, r.case_index), f);
      if (!added)
        throw UsageError("overlap: the row of set " + std::to_string(r.set_index) + ", case " +
                         std::to_string(r.case_index) + " is in " + it->second + " and in " + f);
      rows.push_back(std::move(r));
    }
  }
  const study::StudyInfo info = study::StudyInfo::of(*first, a.shards.front());
  if (rows.size() != info.runs()) {
    for (std::size_t s = 0; s < info.sets.size(); ++s)
      for (std::size_t c = 0; c < info.cases.size(); ++c)
        if (!owner.count({static_cast<std::int64_t>(s), static_cast<std::int64_t>(c)}))
          throw UsageError("gap: no shard holds the row of set " + std::to_string(s) + " (" + info.sets[s].key +
                           "), case " + info.cases[c].name + " (" + std::to_string(info.runs() - rows.size()) +
                           " rows missing; a shard is missing or unfinished: --resume it)");
  }
  std::error_code ec;
  if (fs::exists(a.out, ec)) throw UsageError("--out: " + a.out + " exists; merge writes a new file");
  storage::StudyStore out(a.out, *first, storage::StudyStore::Existing::Refuse);
  out.add(sorted(std::move(rows)));
  std::cerr << "merged " << a.shards.size() << (a.shards.size() == 1 ? " shard" : " shards") << " into " << a.out << ": "
            << info.runs() << (info.runs() == 1 ? " row\n" : " rows\n");
}

void run_report(const ReportArgs& a) {
  if (std::error_code missing; !fs::exists(a.file, missing)) throw UsageError(a.file + ": no such file");
  refuse_output_over_input("--csv", a.csv, a.file, "the study database");
  check_csv_option(a.csv, a.json);
  const auto h = storage::StudyStore::header_of(a.file);
  if (!h) throw UsageError(a.file + ": holds no study");
  const study::StudyInfo info = study::StudyInfo::of(*h, a.file);
  const auto rows = sorted(storage::StudyStore::rows_of(a.file));
  if (!a.heatmap_cp.empty() && a.svg.empty()) throw UsageError("--heatmap-cp needs --svg");
  if (std::error_code ec; !a.svg.empty() && fs::exists(a.svg, ec) && !fs::is_directory(a.svg, ec))
    throw UsageError("--svg: " + a.svg + " exists and is not a directory");
  std::optional<std::string> cp;
  if (!a.heatmap_cp.empty()) {
    try {
      cp = study::grid_cp(info, a.heatmap_cp);
    } catch (const study::FigureError& e) {
      throw UsageError(std::string("--heatmap-cp: ") + e.what());
    }
  }
  if (!a.csv.empty()) write_csv(a.csv, info, rows);
  const study::Analysis analysis = study::analyse(info, rows, a.limit);
  print_analysis(analysis, info, a.json, a.csv);
  if (!a.svg.empty()) {
    const study::FiguresWritten w = study::write_figures(info, rows, analysis, a.svg, cp);
    for (const std::string& note : w.notes) std::cerr << "study report: " << note << "\n";
    std::cerr << "study report: " << w.files.size() << " figures in " << a.svg << ":";
    for (const auto& f : w.files) std::cerr << " " << f.filename().string();
    std::cerr << "\n";
  }
}

}  // namespace

void add_study_command(CLI::App& app) {
  auto args = std::make_shared<StudyArgs>();
  CLI::App* cmd = app.add_subcommand(
      "study", "Parameter study: every set of a grid of controller parameters over load cases (one row per set and "
               "case, equal to alc replay with those parameters), the Eq. 8 optimum per case, the best set on every "
               "case and the Pareto front of P99 against Pd (docs/study.md).");
  cmd->add_option("--grid", args->grid, "paper (Tab. 1 of seed 004: 2,191 sets) or a TOML grid file");
  cmd->add_option("--case", args->case_name, "Built-in load case: A, B, C, D, S16, H1-H7, all (A-D) or heldout (H1-H5)");
  cmd->add_option("files", args->files, "Scenario CSV files (instead of --case)");
  add_whole_option(cmd, "--jobs", args->jobs, "Worker threads (default 0: every core)", 0, 4096);
  cmd->add_option("--db", args->db, "Store the rows in this SQLite file as they finish (needed for --resume)");
  cmd->add_option("--csv", args->csv,
                  "Write the rows to this CSV file (one per set and case); - writes them to stdout and the analysis to "
                  "stderr");
  cmd->add_flag("--json", args->json, "Print the analysis as JSON");
  cmd->add_option("--shard", args->shard, "Run the I-th of N deterministic slices (1 <= I <= N), e.g. 2/8");
  cmd->add_flag("--resume", args->resume, "Continue the study in --db: reuse its rows, compute the rest");
  CLI::Option* bench = cmd->add_flag("--bench", args->bench,
                "Benchmark: the grid with shared work, then a random sample as independent replays; prints runs/s, "
                "work saved, peak RSS and the ratio");
  add_whole_option(cmd, "--bench-sample", args->bench_sample, "Independent replays of the benchmark's baseline", 1,
                   100000000)
      ->needs(bench);
  cmd->add_option_function<std::string>("--bench-seed", [args](const std::string& s) { args->bench_seed = parse_seed(s, "--bench-seed"); },
                                        "Seed of the benchmark's sample (default 1)")
      ->needs(bench);
  cmd->add_flag("--quiet", args->quiet, "No progress on stderr");

  auto merge = std::make_shared<MergeArgs>();
  CLI::App* m = cmd->add_subcommand("merge", "Join shard files (--shard I/N with --db) into one study file; refuses "
                                             "overlaps, gaps and shards of another grid, case set or version");
  m->add_option("--out", merge->out, "The merged study file (new)")->required();
  m->add_option("shards", merge->shards, "Shard files")->required();
  m->callback([merge] { run_merge(*merge); });

  auto report = std::make_shared<ReportArgs>();
  CLI::App* r = cmd->add_subcommand("report", "The analysis of a study file (Eq. 8 optimum per case, the best set on "
                                              "every case, the Pareto front)");
  r->add_option("file", report->file, "Study file (--db of alc study, or alc study merge --out)")->required();
  r->add_flag("--json", report->json, "Print the analysis as JSON");
  r->add_option("--csv", report->csv, "Write the rows to this CSV file (as alc study --csv; - for stdout)");
  r->add_option("--svg", report->svg,
                 "Write SVG figures into this directory (created if missing): pareto-<case>.svg per case, "
                 "heatmap-p99-cp<H>.svg and heatmap-pd-cp<H>.svg (docs/study.md, Figures)");
  r->add_option("--heatmap-cp", report->heatmap_cp,
                "CP length [h] of the heat maps, a value of the grid's cp axis (default: the CP of the first "
                "case's Eq. 8 optimum, else the first)");
  cmd->callback([args, cmd] {
    if (cmd->got_subcommand("merge") || cmd->got_subcommand("report")) return;
    run_study_command(*args);
  });
  r->callback([report] { run_report(*report); });
}

}  // namespace alc::cli
