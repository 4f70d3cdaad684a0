// A writer killed with SIGKILL leaves a sound database holding everything committed before the kill.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdint>

#include "storage/history_reader.hpp"
#include "storage/history_tools.hpp"
#include "storage_test_support.hpp"

using namespace alc::storage;
using alc::storage::test::ScratchDir;

TEST_CASE("SIGKILL in the middle of writing loses only the uncommitted batch", "[storage]") {
  ScratchDir dir;
  const auto file = dir / "killed.sqlite";
  int pipe_fd[2];
  REQUIRE(pipe(pipe_fd) == 0);
  const pid_t child = fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    close(pipe_fd[0]);
    try {
      WriterOptions options;
      options.batch_size = 64;
      HistoryWriter writer(file, options);
      const RunId id = writer.begin_run(test::small_run());
      for (std::int64_t k = 0;; ++k) {
        writer.add(test::sample_at(id, k));
        writer.add(PredictionRecord{id, 60.0 * static_cast<double>(k), {0.5, -0.5}, {1.0, 2.0}});
        if (k % 100 == 99) writer.save_snapshot({id, 60.0 * static_cast<double>(k), k + 1, "test/1", true, "{}"});
        if (writer.pending() == 0) {
          // Tell the parent how many samples are committed (only after the commit returned).
          const std::int64_t committed = k + 1;
          if (write(pipe_fd[1], &committed, sizeof committed) != sizeof committed) _exit(3);
        }
      }
    } catch (...) {
      _exit(2);
    }
  }
  close(pipe_fd[1]);
  std::int64_t committed = 0;
  std::int64_t value = 0;
  while (committed < 5000 && read(pipe_fd[0], &value, sizeof value) == sizeof value) committed = value;
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  // Reports already in the pipe were committed too.
  while (read(pipe_fd[0], &value, sizeof value) == sizeof value) committed = value;
  close(pipe_fd[0]);
  REQUIRE(WIFSIGNALED(status));
  REQUIRE(committed >= 5000);

  const CheckReport report = check_history(file);  // integrity_check + the project's checks
  for (const auto& problem : report.problems) UNSCOPED_INFO(problem);
  CHECK(report.ok());
  const HistoryReader reader(file);
  const auto runs = reader.runs();
  REQUIRE(runs.size() == 1);
  CHECK(runs[0].status == RunStatus::Running);  // killed: never ended
  const auto samples = reader.input_samples(runs[0].run_id);
  CHECK(static_cast<std::int64_t>(samples.size()) >= committed);
  for (std::size_t k = 0; k < samples.size(); ++k) REQUIRE(samples[k].sample_index == static_cast<std::int64_t>(k));
  const auto snapshot = reader.latest_snapshot(runs[0].run_id);
  REQUIRE(snapshot);
  CHECK(snapshot->next_sample_index <= static_cast<std::int64_t>(samples.size()));
}
