#pragma once
// Shared by the nc_interface tests: the fixed command set of the reference texts, file helpers.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

#include "nc_interface/commands.hpp"
#include "nc_interface/jsonl.hpp"

namespace alc::nc::test {

// Axis offsets with A and C (the A–C table) on work offset `work_offset` (1 = G54).
inline AxisOffsets offsets(double x, double y, double z, double a, double c, int work_offset = 1) {
  AxisOffsets o;
  o.x_mm = x;
  o.y_mm = y;
  o.z_mm = z;
  o.a_deg = a;
  o.c_deg = c;
  o.work_offset = work_offset;
  return o;
}

// The reviewed reference texts in tests/nc_interface/reference/ are written from these commands.
inline std::vector<NcCommand> reference_commands() {
  AxisOffsets first;
  first.x_mm = 0.0123;
  first.y_mm = -0.004;
  first.z_mm = 0.01;
  first.a_deg = 0.001;
  first.c_deg = -0.002;
  AxisOffsets rounding;  // 0.00004 -> 0.0000, -0.00004 -> 0.0000 (not -0.0000), halves away from zero
  rounding.x_mm = 0.00004;
  rounding.y_mm = -0.00004;
  rounding.z_mm = 0.00005;
  rounding.a_deg = -0.00005;
  rounding.c_deg = 0.1;
  rounding.work_offset = 2;
  AxisOffsets b_axis;  // a B–C machine
  b_axis.x_mm = -0.1;
  b_axis.y_mm = 0.1;
  b_axis.z_mm = 0.0;
  b_axis.a_deg.reset();
  b_axis.b_deg = 0.01;
  b_axis.c_deg = -0.01;
  b_axis.work_offset = 6;
  return {first, ProbeInterval{30.0, std::nullopt}, rounding, ProbeInterval{std::nullopt, std::nullopt}, b_axis,
          ProbeInterval{5.5, 3600.0}};
}

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}

// A fresh, empty directory under the system temp dir, named after the test.
inline std::filesystem::path fresh_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("alc_nc_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// The commands that `alc nc` printed to stderr as not delivered: its lines that start with '{',
// read back as JSON lines (so they are exactly what a resend would read).
inline std::vector<NcCommand> undelivered_commands(const std::string& err) {
  std::istringstream in(err);
  std::string json;
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line.front() == '{') json += line + "\n";
  std::istringstream lines(json);
  return read_commands_jsonl(lines, "<stderr>");
}

}  // namespace alc::nc::test
