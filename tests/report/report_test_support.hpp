#pragma once
// Shared by the report tests: a short history (case A cut to 30 h: CP, an NG phase, model updates,
// offsets sent to an NC directory, and one refused offset command added), the report written from
// it, and headless chromium run on a file.
#include <catch2/catch.hpp>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "../cli_support.hpp"
#include "report/html_report.hpp"
#include "runtime/replay.hpp"
#include "scenarios/load_cases.hpp"
#include "common/atomic_file.hpp"
#include "storage/history_writer.hpp"

namespace alc::report::test {

// Occurrences of `what` in `text`.
inline std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + what.size())) ++n;
  return n;
}

inline constexpr double kHours = 30.0;  // [h] of case A: CP 6.5 h, a breach at 8.5 h, NG, Post-CP

struct ShortHistory {
  std::filesystem::path db;
  runtime::ReplayReport replay;  // what alc replay printed for it
  storage::RunId run = 0;
};

// A fresh directory per test process and name, removed with its files at the end of the test.
struct Scratch : alc_test::Scratch {
  explicit Scratch(const std::string& name)
      : alc_test::Scratch(std::filesystem::temp_directory_path() /
                          ("alc-report-test-" + std::to_string(::getpid()) + "-" + name)) {}
};

inline ShortHistory short_history(const std::filesystem::path& dir) {
  scenarios::LoadCaseSpec spec = scenarios::load_case_spec("A");
  spec.info.duration_h = kHours;
  const auto simulated = scenarios::simulate_load_case(spec, spec.info.default_seed);
  ShortHistory h;
  h.db = dir / "history.sqlite";
  runtime::ReplayOptions o;
  o.source = "case A (30 h)";
  o.parameters.acl_linear_um = 2.5;  // breaches within 30 h: NG phases to draw
  o.db = h.db;
  o.nc = runtime::NcOutputSetup{dir / "nc", nc::Dialect::LinuxCNC};
  runtime::Replay replay(simulated.scenario, std::move(o));
  replay.run();
  h.replay = replay.report();
  h.run = *replay.run_id();
  // One command the safety gate refused (a replay within the default limits refuses none).
  storage::HistoryWriter writer(h.db);
  writer.add(storage::NcCommandRecord{h.run, 20 * 3600.0, "offsets", "{\"X_um\": 900}", "file:test", false,
                                      "X step 900 µm exceeds the limit of 50 µm", std::nullopt, ""});
  writer.close();
  return h;
}

// Runs SQL on a history file (to make the states a report must show apart).
inline void exec_sql(const std::filesystem::path& file, const std::string& sql) {
  sqlite3* db = nullptr;
  REQUIRE(sqlite3_open(file.c_str(), &db) == SQLITE_OK);
  char* error = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error);
  INFO((error ? error : ""));
  sqlite3_free(error);
  sqlite3_close(db);
  REQUIRE(rc == SQLITE_OK);
}

// The short history with its first `failed` accepted offset commands marked not delivered (delivered
// 0, the sink's error) and the next `unsettled` not settled (delivered NULL), as a failed --nc-out and
// a kill leave them; the rest stay delivered.
inline void mark_undelivered(const std::filesystem::path& db, int failed, int unsettled) {
  const std::string accepted =
      "SELECT nc_command_id FROM nc_commands WHERE accepted = 1 AND kind = 'offsets' ORDER BY nc_command_id";
  exec_sql(db, "UPDATE nc_commands SET delivered = 0, delivery_message = 'cannot create nc: Not a directory' "
               "WHERE nc_command_id IN (" + accepted + " LIMIT " + std::to_string(failed) + ");"
               "UPDATE nc_commands SET delivered = NULL, delivery_message = '' WHERE nc_command_id IN (" +
                   accepted + " LIMIT " + std::to_string(unsettled) + " OFFSET " + std::to_string(failed) + ");");
}

inline void io_write(const std::filesystem::path& file, const std::string& text) {
  io::write_file_atomically(file, text);
}

// A small study of case A in DIR/study.sqlite (`alc study`, 2 x 2 sets: interval 2 and 8 h, ng-meas 6
// and 12), its grid in DIR/grid.toml; `tag` names the CLI run's scratch files.
inline std::filesystem::path small_study(const std::filesystem::path& dir, const std::string& tag) {
  std::ofstream(dir / "grid.toml") << "cp = [6.5]\ninterval = [2, 8]\nng-interval = [10]\nng-meas = [6, 12]\n";
  const auto db = dir / "study.sqlite";
  const auto r = alc_test::run_alc("study --grid \"" + (dir / "grid.toml").string() + "\" --case A --quiet --db \"" +
                                       db.string() + "\"",
                                   tag);
  REQUIRE(r.exit_code == 0);
  return db;
}

struct Browser {
  int exit_code = -1;
  std::string out, err;
};

// chromium --headless=new on a URL, with its own profile; console messages go to stderr
// (--enable-logging=stderr: lines with ":CONSOLE").
inline Browser chromium_url(const std::filesystem::path& dir, const std::string& args, const std::string& url) {
  const std::string cmd = "timeout 120 chromium --headless=new --no-sandbox --disable-gpu --no-first-run "
                          "--disable-background-networking --disable-component-update --disable-sync "
                          "--user-data-dir=\"" +
                          (dir / "profile").string() + "\" --enable-logging=stderr --v=0 " + args + " \"" + url +
                          "\" >\"" + (dir / "browser.out").string() + "\" 2>\"" + (dir / "browser.err").string() +
                          "\" </dev/null";
  const int status = std::system(cmd.c_str());
  Browser b;
  if (WIFEXITED(status)) b.exit_code = WEXITSTATUS(status);
  b.out = alc_test::slurp(dir / "browser.out");
  b.err = alc_test::slurp(dir / "browser.err");
  return b;
}

// The same on a local file.
inline Browser chromium(const std::filesystem::path& dir, const std::string& args, const std::filesystem::path& page) {
  return chromium_url(dir, args, "file://" + page.string());
}

// The text of <pre id="alc-dom-check"> in a dumped DOM, entities decoded (what the page's DOM-check
// script wrote: the charts' series and points, script errors).
inline std::string dom_check(const std::string& dom) {
  const std::string open = "<pre id=\"alc-dom-check\" data-done=\"1\">";
  const auto a = dom.find(open);
  if (a == std::string::npos) return "";
  const auto b = dom.find("</pre>", a);
  std::string raw = dom.substr(a + open.size(), b - a - open.size()), text;
  for (std::size_t i = 0; i < raw.size(); ++i) {
    if (raw.compare(i, 5, "&amp;") == 0) text += '&', i += 4;
    else if (raw.compare(i, 4, "&lt;") == 0) text += '<', i += 3;
    else if (raw.compare(i, 4, "&gt;") == 0) text += '>', i += 3;
    else text += raw[i];
  }
  return text;
}

}  // namespace alc::report::test
