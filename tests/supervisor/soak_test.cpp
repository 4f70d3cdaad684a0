// The soak: `alc supervise` on a real mosquitto with the twin gateway playing load case A (extended to
// ALC_SOAK_DAYS days of machine time, default 1) at full speed and answering probe requests in closed
// loop. Prints, at day 1, 10, 20, 30, 45, 60, 90 (those reached) and the end, the supervisor's RSS, samples/s and the
// history's and inbox's sizes; asserts only correctness (every sample stored once, in order), never
// speed or memory. scripts/supervisor_soak.sh runs it for 30 days (the README's figures).
#include <catch2/catch.hpp>

#include <cstdio>
#include <iostream>

#include "storage/history_reader.hpp"
#include "supervisor_test_support.hpp"

using namespace alc;
using namespace alc::supervisor_test;

namespace {

// kB of /proc/<pid>/status's `key` (VmRSS, VmHWM).
long status_kb(pid_t pid, const std::string& key) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind(key + ":", 0) == 0) return std::stol(line.substr(key.size() + 1));
  return -1;
}

// Bytes of a SQLite file with its WAL.
std::uintmax_t db_bytes(const fs::path& db) {
  std::uintmax_t n = 0;
  for (const char* suffix : {"", "-wal"}) {
    std::error_code ec;
    const auto size = fs::file_size(db.string() + suffix, ec);
    if (!ec) n += size;
  }
  return n;
}

}  // namespace

TEST_CASE("soak: days of machine time at full speed through the broker store every sample once", "[soak]") {
  const char* env = std::getenv("ALC_SOAK_DAYS");
  const int days = env ? std::max(1, std::atoi(env)) : 1;
  MosquittoLib lib;
  const fs::path dir = temp_dir("soak");
  Broker broker(dir, false);
  scenarios::LoadCaseSpec spec = scenarios::load_case_spec("A");
  spec.info.duration_h = days * 24.0 + 1.0;  // the last hour answers the last probe request
  const scenarios::Scenario s = scenarios::simulate_load_case(spec, spec.info.default_seed).scenario;
  write(dir / "s.toml", case_config(s, broker.port));
  Client c(broker.port, "twin-gateway");
  Gateway g(s, c);
  g.forget = true;
  const pid_t pid = start_supervisor(dir);
  const ChildGuard guard{pid};
  const auto start = std::chrono::steady_clock::now();
  auto row_at_day = [&](double d) {
    std::size_t row = 0;
    while (row < s.samples() && s.time_s[row] < s.time_s[0] + d * 86400.0) ++row;
    return row;
  };
  std::printf("soak: load case A, %d day(s) of machine time, %zu samples at %.0f s\n", days, row_at_day(days),
              s.time_s[1] - s.time_s[0]);
  std::printf("%6s %9s %9s %10s %10s %10s %12s %10s\n", "day", "samples", "wall [s]", "samples/s", "RSS [kB]",
              "peak [kB]", "history [kB]", "inbox [kB]");
  std::vector<int> marks;
  for (int d : {1, 10, 20, 30, 45, 60, 90})
    if (d < days) marks.push_back(d);
  marks.push_back(days);
  for (const int d : marks) {
    const std::size_t rows = row_at_day(d);
    if (d == days) g.play(rows, SIZE_MAX, 50);  // then every row is processed and nothing is held
    else g.play(SIZE_MAX, rows, 50);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const auto done = g.processed();
    std::printf("%6d %9lld %9.1f %10.0f %10ld %10ld %12ju %10ju\n", d, static_cast<long long>(done), wall, done / wall,
                status_kb(pid, "VmRSS"), status_kb(pid, "VmHWM"), db_bytes(dir / "h.sqlite") / 1024,
                db_bytes(dir / "h.sqlite.inbox") / 1024);
    std::fflush(stdout);
  }
  const auto processed = static_cast<std::size_t>(g.processed());
  ::kill(pid, SIGTERM);
  CHECK(wait_exit(pid) == 0);
  const storage::HistoryReader r(dir / "h.sqlite");
  const auto samples = r.input_samples(r.runs().back().run_id);
  CHECK(samples.size() == processed);
  CHECK(processed >= row_at_day(days));
  std::size_t in_order = 0;
  for (std::size_t k = 0; k < samples.size(); ++k)
    in_order += samples[k].sample_index == static_cast<std::int64_t>(k) && samples[k].time_s == s.time_s[k];
  CHECK(in_order == samples.size());
  CHECK(r.probe_measurements(r.runs().back().run_id).size() >= static_cast<std::size_t>(days));
  std::error_code ec;
  fs::remove_all(dir, ec);  // tens of MB after a long soak
}
