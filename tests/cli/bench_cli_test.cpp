// alc bench --long: the long-run benchmark prints a row per checkpoint for the default learning
// window and for --window inf (figures only: no timing is asserted), and refuses a case it cannot stretch.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "../cli_support.hpp"

namespace {

// The rows of the table: lines that start with the window label.
std::vector<std::vector<std::string>> rows_of(const std::string& out) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(out);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::vector<std::string> f;
    for (std::string w; fields >> w;) f.push_back(w);
    if (!f.empty() && (f[0] == "14" || f[0] == "inf")) rows.push_back(f);
  }
  return rows;
}

}  // namespace

TEST_CASE("alc bench --long prints each checkpoint with and without the learning window") {
  const alc_test::CliRun r = alc_test::run_alc("bench --long 12 --case B", "bench_long");
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("case B stretched to 12 days: 17281 samples") != std::string::npos);
  const auto rows = rows_of(r.out);
  REQUIRE(rows.size() == 4);  // days 10 and 12, for "14 d" and "inf"
  // "14 d  DAY peak rss µs kept snapshot db P99" and "inf  DAY peak rss µs kept snapshot db P99".
  CHECK(rows[0][0] == "14");
  CHECK(rows[0][2] == "10");
  CHECK(rows[1][2] == "12");
  CHECK(rows[2][0] == "inf");
  CHECK(rows[3][1] == "12");
  // Within 14 days nothing is trimmed: both keep every sample, and decide the same (same P99).
  CHECK(rows[1][6] == "17281");
  CHECK(rows[3][5] == "17281");
  CHECK(rows[1].back() == rows[3].back());
  CHECK(std::stod(rows[1][8]) > 0.5);  // 12 days of history: several MB, WAL included
}

TEST_CASE("alc bench --long refuses a case that is not one of A-D, and leaves no scratch directory") {
  // The program's temp directory (TMPDIR) is one of this test's own, so that what it leaves is seen.
  const auto tmp = alc_test::work_dir("bench_refused") / "tmp";
  std::filesystem::create_directories(tmp);
  const char* before = std::getenv("TMPDIR");
  const std::string saved = before ? before : "";
  ::setenv("TMPDIR", tmp.c_str(), 1);
  const alc_test::CliRun r = alc_test::run_alc("bench --long 5 --case S16", "bench_long");
  if (before) ::setenv("TMPDIR", saved.c_str(), 1); else ::unsetenv("TMPDIR");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("no load case 'S16'") != std::string::npos);
  std::vector<std::string> left;  // (run_alc's own output directory is made there too: not counted)
  for (const auto& e : std::filesystem::directory_iterator(tmp))
    if (e.path().filename().string().rfind("alc-bench-", 0) == 0) left.push_back(e.path().filename().string());
  INFO("scratch directories left in TMPDIR: " << left.size());
  CHECK(left.empty());
}
