#pragma once
// Shared by the runtime tests: fresh history files and replay options.
#include <filesystem>
#include <string>
#include <unistd.h>

#include "../cli_support.hpp"
#include "runtime/replay.hpp"

namespace alc::runtime::test {

// A fresh history file path for one test (removed with its WAL files first, and again when the test
// process exits).
inline std::filesystem::path temp_db(const std::string& name) {
  const auto p = std::filesystem::temp_directory_path() /
                 ("alc-runtime-test-" + std::to_string(::getpid()) + "-" + name + ".sqlite");
  for (const char* ext : {"", "-wal", "-shm"}) {
    std::filesystem::remove(p.string() + ext);
    alc_test::remove_at_exit(p.string() + ext);
  }
  return p;
}

inline ReplayOptions in_memory(AlcParameters p, Observer* observer = nullptr) {
  ReplayOptions o;
  o.parameters = std::move(p);
  if (observer) o.observers.push_back(observer);
  return o;
}

}  // namespace alc::runtime::test
