#pragma once
// Helpers shared by the storage tests: a scratch directory, a small run, raw SQLite access.
#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>

#include "storage/history_writer.hpp"

namespace alc::storage::test {

// A fresh directory under the system temp dir, removed with everything in it at scope exit.
struct ScratchDir {
  std::filesystem::path path;
  ScratchDir() {
    std::random_device rd;
    path = std::filesystem::temp_directory_path() /
           ("alc-storage-test-" + std::to_string(::getpid()) + "-" + std::to_string(rd()));
    std::filesystem::create_directories(path);
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::permissions(path, std::filesystem::perms::owner_all, ec);
    std::filesystem::remove_all(path, ec);
  }
  std::filesystem::path operator/(const std::string& name) const { return path / name; }
};

inline RunRecord small_run() {
  RunRecord run;
  run.source = "case A";
  run.config_json = R"({"cp_h": 6.5, "post_cp_interval_h": 2, "ng_interval_min": 10, "ng_count": 12})";
  run.software_version = "alc test";
  run.input_names = {"T_ENV", "T_FLUID", "n_C"};
  run.output_names = {"E_X0C", "E_A0C"};
  run.offset_names = {"X_um", "C_mdeg"};
  return run;
}

inline InputSampleRecord sample_at(RunId run, std::int64_t k) {
  const double t = 60.0 * static_cast<double>(k);
  return {run, k, t, {20.0 + 0.001 * static_cast<double>(k), 21.5, k % 2 ? 500.0 : 0.0}};
}

inline std::string read_bytes(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

inline void write_bytes(const std::filesystem::path& file, const std::string& bytes) {
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
}

// A raw SQLite connection for building hostile files and peeking under the writer.
struct RawDb {
  sqlite3* db = nullptr;
  explicit RawDb(const std::filesystem::path& file) {
    if (sqlite3_open(file.c_str(), &db) != SQLITE_OK) throw std::runtime_error("open failed");
  }
  ~RawDb() { sqlite3_close(db); }
  int exec(const std::string& sql) { return sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr); }
  long long scalar(const std::string& sql) {
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(db, sql.c_str(), -1, &st, nullptr);
    long long value = -1;
    if (sqlite3_step(st) == SQLITE_ROW) value = sqlite3_column_int64(st, 0);
    sqlite3_finalize(st);
    return value;
  }
  std::string text(const std::string& sql) {
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(db, sql.c_str(), -1, &st, nullptr);
    std::string value = "(no row)";
    if (sqlite3_step(st) == SQLITE_ROW) value = reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
    sqlite3_finalize(st);
    return value;
  }
};

}  // namespace alc::storage::test
