// `alc db bench`: records per second written, batched against one transaction per record.
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "storage/history_tools.hpp"
#include "storage/history_writer.hpp"
#include "storage/storage_error.hpp"

namespace alc::storage {

namespace {

// Creates a new, empty file `alc-bench-<pid>-<n>.sqlite` in `directory` (O_EXCL: never one that
// exists, nor one that another process claims at the same moment). A writer takes a zero-byte file
// as a new database.
std::filesystem::path claim_scratch_file(const std::filesystem::path& directory, std::size_t first) {
  for (std::size_t n = first; n < first + 1000; ++n) {
    const auto file = directory / ("alc-bench-" + std::to_string(::getpid()) + "-" + std::to_string(n) + ".sqlite");
    std::error_code ec;
    if (std::filesystem::exists(file.string() + "-wal", ec) || std::filesystem::exists(file.string() + "-shm", ec))
      continue;
    const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd >= 0) {
      ::close(fd);
      return file;
    }
    if (errno == EEXIST) continue;
    const int err = errno;
    throw StorageError(err == ENOENT ? StorageErrorKind::NotFound
                       : (err == EACCES || err == EPERM || err == EROFS) ? StorageErrorKind::ReadOnly
                                                                          : StorageErrorKind::Io,
                       file, std::string("bench: cannot create a scratch database: ") + std::strerror(err));
  }
  throw StorageError(StorageErrorKind::Io, directory, "bench: no free scratch file name alc-bench-<pid>-<n>.sqlite");
}

// Writes a synthetic run (a sample and a prediction per step) into a new scratch file, removes
// the file, and returns the elapsed seconds.
double write_run(const std::filesystem::path& directory, const BenchOptions& options, std::size_t batch_size,
                 std::vector<std::filesystem::path>& files) {
  const auto file = claim_scratch_file(directory, files.size());  // a name of its own per mode
  files.push_back(file);
  struct Remove {  // also when the writer throws (disk full): only the files this run created
    std::filesystem::path file;
    ~Remove() {
      std::error_code ec;
      for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(file.string() + suffix, ec);
    }
  } remove{file};
  const auto start = std::chrono::steady_clock::now();
  {
    HistoryWriter writer(file, WriterOptions{.batch_size = batch_size});
    RunRecord run;
    run.source = "bench";
    run.software_version = "bench";
    for (int i = 0; i < options.inputs; ++i) run.input_names.push_back(std::string("T").append(std::to_string(i)));
    run.output_names = {"E_X0C", "E_Y0C", "E_Z0T", "E_R0T", "E_A0C", "E_B0C", "E_C0C"};
    run.offset_names = {"X_um", "Y_um", "Z_um", "A_mdeg", "C_mdeg"};
    const RunId id = writer.begin_run(run);
    InputSampleRecord sample{id, 0, 0.0, std::vector<double>(static_cast<std::size_t>(options.inputs))};
    PredictionRecord prediction{id, 0.0, std::vector<double>(7), std::vector<double>(5)};
    for (std::int64_t k = 0; k < options.samples; ++k) {
      sample.sample_index = k;
      sample.time_s = prediction.time_s = 60.0 * static_cast<double>(k);
      for (std::size_t i = 0; i < sample.values.size(); ++i) sample.values[i] = 20.0 + std::sin(0.001 * static_cast<double>(k + static_cast<std::int64_t>(i)));
      for (std::size_t i = 0; i < prediction.predicted.size(); ++i) prediction.predicted[i] = 0.5 * sample.values[i % sample.values.size()];
      writer.add(sample);
      writer.add(prediction);
    }
    writer.end_run(id, RunStatus::Finished);
  }
  const auto stop = std::chrono::steady_clock::now();
  return std::chrono::duration<double>(stop - start).count();
}

}  // namespace

BenchResult bench_history(const std::filesystem::path& directory, const BenchOptions& options) {
  if (options.samples < 1 || options.inputs < 1 || options.batch_size < 1)
    throw StorageError(StorageErrorKind::InvalidArgument, directory, "bench: samples, inputs and batch size must be positive");
  BenchResult result;
  result.records = 2 * options.samples;
  const double batched = write_run(directory, options, options.batch_size, result.scratch_files);
  const double unbatched = write_run(directory, options, 1, result.scratch_files);
  result.batched_records_per_s = static_cast<double>(result.records) / batched;
  result.unbatched_records_per_s = static_cast<double>(result.records) / unbatched;
  return result;
}

}  // namespace alc::storage
