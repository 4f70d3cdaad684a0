#pragma once
// Running the built `alc` program (ALC_CLI_PATH) from a test: its exit code, stdout and stderr,
// and a scratch directory per test process (ctest -j and the sanitizer run must not share files),
// removed when the process exits.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

namespace alc_test {

struct CliRun {
  int exit_code = -1;
  int signal = 0;        // the signal that ended the program (from /bin/sh's 128 + N), else 0
  std::string out, err;
};

inline std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// How often `what` occurs in `text` (overlapping occurrences counted).
inline std::size_t occurrences(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// The work directories this test process made, removed with their files when it exits.
struct WorkDirs {
  std::vector<std::filesystem::path> made;
  ~WorkDirs() {
    for (const auto& dir : made) {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  }
};
// `dir` (made by this process) is removed when the process exits.
inline void remove_at_exit(const std::filesystem::path& dir) {
  static WorkDirs dirs;
  if (std::find(dirs.made.begin(), dirs.made.end(), dir) == dirs.made.end()) dirs.made.push_back(dir);
}

// <tmp>/alc_<tag>_<pid>, created on first use and removed when the test process exits.
inline std::filesystem::path work_dir(const std::string& tag) {
  const auto dir = std::filesystem::temp_directory_path() / ("alc_" + tag + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);  // (one left by a crashed process of the same pid is ours now)
  remove_at_exit(dir);
  return dir;
}

// A fresh, empty directory `dir` for one test, removed with its files when the test ends.
struct Scratch {
  explicit Scratch(std::filesystem::path d) : dir(std::move(d)) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
  }
  ~Scratch() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
  std::filesystem::path dir;
};

// Runs `alc ARGS` (ARGS as a shell would split them) with stdin from /dev/null.
inline CliRun run_alc(const std::string& args, const std::string& tag) {
  const auto dir = work_dir(tag);
  const std::string cmd = std::string("\"") + ALC_CLI_PATH + "\" " + args + " >\"" + (dir / "out").string() +
                          "\" 2>\"" + (dir / "err").string() + "\" </dev/null";
  const int status = std::system(cmd.c_str());
  CliRun r;
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  if (r.exit_code > 128) r.signal = r.exit_code - 128;
  r.out = slurp(dir / "out");
  r.err = slurp(dir / "err");
  return r;
}

}  // namespace alc_test
