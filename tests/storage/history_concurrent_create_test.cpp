// Two writers started at the same instant on a new file (issue 13 item 11): creating the schema is
// atomic against a concurrent creator, the loser waits and then opens the finished history.
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <catch2/catch.hpp>
#include <cstdio>
#include <cstring>
#include <string>

#include "storage/history_reader.hpp"
#include "storage/history_tools.hpp"
#include "storage/storage_error.hpp"
#include "storage_test_support.hpp"

using namespace alc::storage;
using alc::storage::test::ScratchDir;

namespace {

// Forks `writers` processes that wait at a barrier (a pipe), then each opens `file` for writing and
// begins a run. Returns the messages of the writers that failed ("" for each that succeeded).
std::vector<std::string> open_at_once(const std::filesystem::path& file, int writers) {
  int barrier[2], results[2];
  REQUIRE(pipe(barrier) == 0);
  REQUIRE(pipe(results) == 0);
  std::vector<pid_t> children;
  for (int w = 0; w < writers; ++w) {
    const pid_t child = fork();
    REQUIRE(child >= 0);
    if (child == 0) {
      close(barrier[1]);
      close(results[0]);
      char go = 0;
      const bool released = read(barrier[0], &go, 1) == 1;  // every writer blocks here until released
      std::string message;
      try {
        if (!released) throw std::runtime_error("barrier broken");
        HistoryWriter writer(file);
        writer.begin_run(test::small_run());
        writer.close();
      } catch (const std::exception& e) {
        message = e.what();
      }
      message = (message.empty() ? "ok" : message).substr(0, 400) + "\n";
      // One write below PIPE_BUF: the lines of the writers never interleave.
      const bool written = write(results[1], message.data(), message.size()) == static_cast<ssize_t>(message.size());
      _exit(written ? 0 : 1);
    }
    children.push_back(child);
  }
  close(barrier[0]);
  close(results[1]);
  const std::string go(static_cast<std::size_t>(writers), 'g');
  REQUIRE(write(barrier[1], go.data(), go.size()) == static_cast<ssize_t>(go.size()));  // all at once
  close(barrier[1]);
  std::string text;
  std::array<char, 512> buffer{};
  for (ssize_t got; (got = read(results[0], buffer.data(), buffer.size())) > 0;) text.append(buffer.data(), static_cast<std::size_t>(got));
  close(results[0]);
  for (const pid_t child : children) {
    int status = 0;
    waitpid(child, &status, 0);
    CHECK(WIFEXITED(status));
  }
  std::vector<std::string> failures;
  for (std::size_t at = 0, end; (end = text.find('\n', at)) != std::string::npos; at = end + 1)
    if (text.substr(at, end - at) != "ok") failures.push_back(text.substr(at, end - at));
  return failures;
}

}  // namespace

TEST_CASE("two writers started at once on a new file both open it: the schema is created once and the other waits",
          "[storage]") {
  ScratchDir dir;
  constexpr int kRounds = 60;
  int failed_rounds = 0;
  std::string reasons;
  for (int round = 0; round < kRounds; ++round) {
    const auto file = dir / ("new_" + std::to_string(round) + ".sqlite");
    const std::vector<std::string> failures = open_at_once(file, 2);
    for (const std::string& f : failures) reasons += "round " + std::to_string(round) + ": " + f + "\n";
    if (!failures.empty()) {
      ++failed_rounds;
      continue;
    }
    // Both runs are in one sound history of the current schema.
    CHECK(HistoryReader(file).runs().size() == 2);
    CHECK(check_history(file).ok());
  }
  INFO(reasons);
  CHECK(failed_rounds == 0);
}
