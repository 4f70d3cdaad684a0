#pragma once
// Logging: one spdlog logger per component ("runtime", "storage", "nc", "probing", "cli",
// "scenarios", ...), all writing to the same configured sinks (stderr and/or a rotating file).
// Lines read `[2026-11-23 18:00:00.123] [info] [storage] message`. Quiet (warn) by default.
#include <spdlog/spdlog.h>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

namespace alc::log {

struct Options {
  spdlog::level::level_enum level = spdlog::level::warn;  // quiet by default
  std::string file;                 // "" = no file; else a rotating file sink
  std::size_t max_file_bytes = 10 * 1024 * 1024;
  std::size_t max_files = 5;
  bool to_stderr = true;
};

// (Re)configures every component logger (existing and future): sinks and level. Throws
// std::runtime_error naming the file on a file that cannot be opened (its directory must exist).
// On a throw the previous configuration stays in force.
void configure(const Options& options);
// The options of the last configure() that succeeded (Options{} before the first).
Options configured();

// The logger of one component, created on first use with the configured sinks; never null.
std::shared_ptr<spdlog::logger> get(const std::string& component);

// While on, a message whose text (component, level and message) was written before is not written
// again, only counted: a study's thousands of runs would repeat their cases' warnings once per set.
// Switching it forgets what was seen and the count. It remembers at most kDistinctTexts texts; new
// texts beyond them are written, not remembered (memory stays bounded).
inline constexpr std::size_t kDistinctTexts = 10000;
void distinct_only(bool on);
// Messages withheld as repeats since distinct_only(true).
std::size_t repeats_withheld();

// "trace","debug","info","warn","error","critical","off" -> level; nullopt otherwise.
std::optional<spdlog::level::level_enum> parse_level(std::string_view text);

}  // namespace alc::log
