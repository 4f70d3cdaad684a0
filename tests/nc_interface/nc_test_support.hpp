#pragma once
// Shared by the nc_interface tests: the fixed command set of the reference texts, file helpers.
#include <catch2/catch.hpp>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

#include "../cli_support.hpp"
#include "nc_interface/commands.hpp"
#include "nc_interface/jsonl.hpp"

namespace alc::nc::test {

// A machine file's base table for one work offset of an A-C machine, every axis written 0 (given:
// G10 L2 may write it; a table must give every axis the program writes).
#define ALC_TEST_ZERO_BASE(wo) "[nc.base." wo "]\nx_mm = 0.0\ny_mm = 0.0\nz_mm = 0.0\na_deg = 0.0\nc_deg = 0.0\n"
inline constexpr const char* kZeroBaseG54 = ALC_TEST_ZERO_BASE("G54");
// The same for every work offset.
inline constexpr const char* kAllBases = ALC_TEST_ZERO_BASE("G54") ALC_TEST_ZERO_BASE("G55") ALC_TEST_ZERO_BASE("G56")
    ALC_TEST_ZERO_BASE("G57") ALC_TEST_ZERO_BASE("G58") ALC_TEST_ZERO_BASE("G59");

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

// A fresh, empty directory under the system temp dir, named after the test (removed when the test
// process exits, as alc_test::work_dir's).
inline std::filesystem::path fresh_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("alc_nc_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  alc_test::remove_at_exit(dir);
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

inline bool on_path(const std::string& program) {
  return std::system(("command -v " + program + " > /dev/null 2>&1").c_str()) == 0;
}

inline std::string require_program(const std::string& program) {
  if (!on_path(program))
    FAIL(program << " not found: install the Debian package linuxcnc-uspace (scripts/test.sh does this)");
  return program;
}

struct Rs274Run {
  int exit_code = -1;
  std::string canon;  // canonical machining commands
  std::string var;    // the var file after the run
};

// Runs LinuxCNC's standalone interpreter on DIR/program.ngc with DIR/params.var = `var_before`.
// Two interpreters at once crash with SIGBUS (exit 135, seen under ctest -j2): they share
// LinuxCNC's fixed shared-memory name, so every run takes /tmp/alc_rs274.lock. A caller outside the
// simulator tests also waits for their lock first (`lock_simulator`: the simulator shares those
// names too); a simulator test, which holds that lock itself, must not.
inline Rs274Run run_rs274(const std::filesystem::path& dir, const std::string& var_before, bool lock_simulator) {
  require_program("rs274");
  write_text(dir / "tool.tbl", "T1 P1 Z0 D0 ;\n");
  write_text(dir / "params.var", var_before);
  std::filesystem::remove(dir / "canon.txt");
  const std::string cmd = "cd '" + dir.string() + "' && " +
                          (lock_simulator ? "flock /tmp/alc_linuxcnc_sim.flock " : "") +
                          "flock /tmp/alc_rs274.lock timeout 60 rs274 -g -t tool.tbl -v params.var program.ngc "
                          "canon.txt > rs274.log 2>&1";
  const int status = std::system(cmd.c_str());
  Rs274Run r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.canon = read_text(dir / "canon.txt");
  r.var = read_text(dir / "params.var");
  return r;
}

// The SET_G5X_OFFSET lines of the G10s. Each "G21 G10 L2 P1 …" line gives USE_LENGTH_UNITS then
// SET_G5X_OFFSET; the interpreter's own SET_G5X_OFFSET at start-up and at M2 come without it, and
// only lines after the program's opening comment count.
inline std::vector<std::string> g10_offsets(const std::string& canon) {
  std::vector<std::string> out;
  std::istringstream in(canon);
  std::string line;
  bool in_program = false;
  bool after_units = false;
  while (std::getline(in, line)) {
    if (line.find("COMMENT(\"ALC thermal compensation") != std::string::npos) in_program = true;
    const auto at = line.find("SET_G5X_OFFSET(");
    if (in_program && at != std::string::npos && after_units) out.push_back(line.substr(at));
    after_units = line.find("USE_LENGTH_UNITS(CANON_UNITS_MM)") != std::string::npos;
  }
  return out;
}

// The value of numbered parameter `parameter` in a var file.
inline double var_value(const std::string& var, int parameter) {
  std::istringstream in(var);
  int p = 0;
  double v = 0.0;
  while (in >> p >> v)
    if (p == parameter) return v;
  FAIL("parameter " << parameter << " not in the var file");
  return 0.0;
}

}  // namespace alc::nc::test
