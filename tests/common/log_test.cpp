// alc::log: one logger per component, all on the configured sinks (stderr, rotating file).
#include <catch2/catch.hpp>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

#include "../cli_support.hpp"
#include "common/log.hpp"

namespace fs = std::filesystem;

namespace {

// A file `name` in this process's scratch directory (removed at exit), not there yet.
fs::path scratch(const std::string& name) {
  const fs::path p = alc_test::work_dir("log_test") / name;
  fs::remove(p);
  return p;
}

using alc_test::slurp;

alc::log::Options to_file(const fs::path& file, spdlog::level::level_enum level) {
  alc::log::Options o;
  o.level = level;
  o.file = file.string();
  o.to_stderr = false;
  return o;
}

// Back to the default (stderr only, warn): releases the test's files.
struct ResetLog {
  ~ResetLog() { alc::log::configure({}); }
};

}  // namespace

TEST_CASE("log: level names parse to spdlog levels, anything else is refused") {
  using alc::log::parse_level;
  CHECK(parse_level("trace") == spdlog::level::trace);
  CHECK(parse_level("debug") == spdlog::level::debug);
  CHECK(parse_level("info") == spdlog::level::info);
  CHECK(parse_level("warn") == spdlog::level::warn);
  CHECK(parse_level("error") == spdlog::level::err);
  CHECK(parse_level("critical") == spdlog::level::critical);
  CHECK(parse_level("off") == spdlog::level::off);
  CHECK_FALSE(parse_level("nope").has_value());
  CHECK_FALSE(parse_level("").has_value());
  CHECK_FALSE(parse_level("INFO").has_value());
  CHECK_FALSE(parse_level("info ").has_value());
}

namespace {
// Whether `text` holds a line "[YYYY-MM-DD HH:MM:SS.mmm" + `rest` (no std::regex: GCC 12 warns
// -Wmaybe-uninitialized inside <regex> in the sanitizer build).
bool has_timestamped_line(const std::string& text, const std::string& rest) {
  constexpr std::string_view kShape = "[dddd-dd-dd dd:dd:dd.ddd";
  for (auto at = text.find(rest); at != std::string::npos; at = text.find(rest, at + 1)) {
    if (at < kShape.size()) continue;
    const std::size_t start = at - kShape.size();
    if (start > 0 && text[start - 1] != '\n') continue;
    bool ok = true;
    for (std::size_t i = 0; i < kShape.size(); ++i) {
      const char c = text[start + i];
      ok = ok && (kShape[i] == 'd' ? c >= '0' && c <= '9' : c == kShape[i]);
    }
    if (ok) return true;
  }
  return false;
}
}  // namespace

TEST_CASE("log: a file sink gets time, level, component and message, and drops lines below the level") {
  const ResetLog reset;
  // A logger that exists before configure() follows the new configuration too.
  const auto early = alc::log::get("runtime");
  REQUIRE(early != nullptr);
  CHECK(alc::log::get("runtime") == early);
  const fs::path file = scratch("line.log");
  alc::log::configure(to_file(file, spdlog::level::info));
  alc::log::get("storage")->info("opened history {}", "h.sqlite");
  alc::log::get("storage")->debug("not at info");
  early->warn("late {}", 7);
  const std::string text = slurp(file);
  CHECK(has_timestamped_line(text, "] [info] [storage] opened history h.sqlite\n"));
  CHECK(text.find("[runtime] late 7") != std::string::npos);
  CHECK(text.find("not at info") == std::string::npos);

  // Raising the level applies to the existing loggers.
  alc::log::configure(to_file(file, spdlog::level::err));
  alc::log::get("storage")->warn("quiet now");
  CHECK(slurp(file).find("quiet now") == std::string::npos);
}

TEST_CASE("log: a small maximum size rotates the file into numbered files, at most max_files of them") {
  const ResetLog reset;
  const fs::path file = scratch("rot.log");
  for (const char* old : {"rot.1.log", "rot.2.log", "rot.3.log"}) fs::remove(file.parent_path() / old);
  alc::log::Options o = to_file(file, spdlog::level::info);
  o.max_file_bytes = 300;
  o.max_files = 2;
  alc::log::configure(o);
  for (int i = 0; i < 40; ++i) alc::log::get("nc")->info("delivery line number {}", i);
  CHECK(fs::exists(file));
  CHECK(fs::exists(file.parent_path() / "rot.1.log"));
  CHECK(fs::exists(file.parent_path() / "rot.2.log"));
  CHECK_FALSE(fs::exists(file.parent_path() / "rot.3.log"));
  CHECK(fs::file_size(file) <= 300);
  CHECK(slurp(file).find("delivery line number 39") != std::string::npos);
}

TEST_CASE("log: a file in a directory that does not exist is refused, naming it, and the old sinks stay") {
  const ResetLog reset;
  const fs::path good = scratch("kept.log");
  alc::log::configure(to_file(good, spdlog::level::info));
  const std::string bad = (fs::temp_directory_path() / "alc_no_such_dir_for_log" / "x.log").string();
  fs::remove_all(fs::path(bad).parent_path());
  CHECK_THROWS_AS(alc::log::configure(to_file(bad, spdlog::level::info)), std::runtime_error);
  CHECK_THROWS_WITH(alc::log::configure(to_file(bad, spdlog::level::info)), Catch::Contains(bad));
  CHECK_FALSE(fs::exists(fs::path(bad).parent_path()));
  alc::log::get("cli")->info("still here");
  CHECK(slurp(good).find("[cli] still here") != std::string::npos);
}

TEST_CASE("log: distinct_only writes each text once and counts the repeats, and once off writes repeats again") {
  const ResetLog reset;
  struct Off {
    ~Off() { alc::log::distinct_only(false); }
  } off;
  const fs::path file = scratch("distinct.log");
  alc::log::configure(to_file(file, spdlog::level::info));
  const auto count = [&](const std::string& what) { return alc_test::occurrences(slurp(file), what); };
  alc::log::distinct_only(true);
  for (int i = 0; i < 3; ++i) alc::log::get("runtime")->warn("E_X0C = {} is beyond the plausible limit", 20.5);
  alc::log::get("runtime")->warn("E_X0C = {} is beyond the plausible limit", 21.5);  // another text
  alc::log::get("storage")->warn("E_X0C = 20.5 is beyond the plausible limit");     // another component
  alc::log::get("runtime")->info("E_X0C = 20.5 is beyond the plausible limit");     // another level
  CHECK(count("[warning] [runtime] E_X0C = 20.5 is beyond") == 1);
  CHECK(count("[runtime] E_X0C = 21.5 is beyond") == 1);
  CHECK(count("[warning] [storage] E_X0C = 20.5 is beyond") == 1);
  CHECK(count("[info] [runtime] E_X0C = 20.5 is beyond") == 1);
  CHECK(alc::log::repeats_withheld() == 2);
  // A line below the level is not written and not counted as a repeat.
  alc::log::get("runtime")->debug("below");
  alc::log::get("runtime")->debug("below");
  CHECK(alc::log::repeats_withheld() == 2);
  alc::log::distinct_only(false);
  CHECK(alc::log::repeats_withheld() == 0);
  alc::log::get("runtime")->warn("E_X0C = {} is beyond the plausible limit", 20.5);
  alc::log::get("runtime")->warn("E_X0C = {} is beyond the plausible limit", 20.5);
  CHECK(count("[warning] [runtime] E_X0C = 20.5 is beyond") == 3);
}
