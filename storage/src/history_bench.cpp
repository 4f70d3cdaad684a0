// `alc db bench`: records per second written, batched against one transaction per record.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <string>

#include "storage/history_tools.hpp"
#include "storage/history_writer.hpp"
#include "storage/storage_error.hpp"

namespace alc::storage {

namespace {

// Writes a synthetic run (a sample and a prediction per step) and returns the elapsed seconds.
double write_run(const std::filesystem::path& file, const BenchOptions& options, std::size_t batch_size) {
  std::filesystem::remove(file);
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
      for (std::size_t i = 0; i < prediction.predicted.size(); ++i) prediction.predicted[i] = 0.5 * sample.values[i];
      writer.add(sample);
      writer.add(prediction);
    }
    writer.end_run(id, RunStatus::Finished);
  }
  const auto stop = std::chrono::steady_clock::now();
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(file.string() + suffix);
  return std::chrono::duration<double>(stop - start).count();
}

}  // namespace

BenchResult bench_history(const std::filesystem::path& directory, const BenchOptions& options) {
  if (options.samples < 1 || options.inputs < 1 || options.batch_size < 1)
    throw StorageError(StorageErrorKind::InvalidArgument, directory, "bench: samples, inputs and batch size must be positive");
  BenchResult result;
  result.records = 2 * options.samples;
  const auto file = directory / "alc-bench-history.sqlite";
  const double batched = write_run(file, options, options.batch_size);
  const double unbatched = write_run(file, options, 1);
  result.batched_records_per_s = static_cast<double>(result.records) / batched;
  result.unbatched_records_per_s = static_cast<double>(result.records) / unbatched;
  return result;
}

}  // namespace alc::storage
