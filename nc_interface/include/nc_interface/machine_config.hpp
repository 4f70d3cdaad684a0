#pragma once
// The machine config file (TOML): kinematic chain, NC output options and safety limits.
// Every key is optional; the defaults are an A–C trunnion, G54, and the SafetyLimits defaults.
//
//   [kinematics]
//   chain = "A-C"                       # or "B-C": sets the default tilt axis (A about x, B about y)
//   tilt_direction = [1.0, 0.0, 0.0]    # unit vector
//   tilt_pivot_mm = [0.0, 0.0, 0.0]
//   table_direction = [0.0, 0.0, 1.0]
//   table_pivot_mm = [0.0, 0.0, 0.0]
//   workpiece_point_mm = [100.0, 0.0, 50.0]
//
//   [nc]
//   work_offset = "G54"
//   linuxcnc_interval_parameter = 3001
//   fanuc_interval_variable = 500
//   fanuc_program_number = 9100
//   sinumerik_interval_r = 100
//   heidenhain_interval_qr = 100
//   heidenhain_program_name = "ALCCOMP"
//   [nc.base.G54]                        # operator's work offset (LinuxCNC, Fanuc write base + comp):
//   x_mm = 0.0  y_mm = 0.0  z_mm = 0.0  a_deg = 0.0  c_deg = 0.0   # every axis written; b_deg for B-C
//                                        # (a_deg on a B-C chain or b_deg on an A-C chain is an error)
//
//   [limits]
//   on_step_violation = "refuse"         # or "split"
//   max_split_steps = 20
//   step_period_s = 60.0                 # [s] machine time per max_step of the controller's offsets
//   [limits.max_offset]                  # x_mm y_mm z_mm a_deg b_deg c_deg
//   [limits.max_step]                    # same keys
#include <filesystem>
#include <stdexcept>
#include <string>

#include "alc/kinematics.hpp"
#include "nc_interface/dialects.hpp"
#include "nc_interface/safety.hpp"

namespace alc::nc {

struct MachineConfig {
  kinematics::MachineChain chain = kinematics::MachineChain::ac_trunnion();
  int work_offset = 1;  // 1 = G54 … 6 = G59, target of the axis offsets
  DialectOptions nc;
  SafetyLimits limits;
  // FNV-1a 64 of the file's bytes as 16 hex digits (read_machine_config; "" when parsed from text):
  // what identifies the machine of a stored run, not the path it was given by.
  std::string content_hash;
};

// A config that cannot be used. The message reads `FILE: key 'KEY': reason: value 'VALUE'`, with
// ` (line N)` after the key where the error names the key's line, and without `: value …` where the
// key has no value (not in the file, e.g. a default that conflicts with another key).
class ConfigError : public std::runtime_error {
 public:
  // `message`, when given, is the whole text (a TOML syntax error: "file:line:column: ...").
  ConfigError(std::string file, std::string key, std::string value, const std::string& reason, int line = 0,
              const std::string& message = "");
  std::string file;
  std::string key;    // dotted path, e.g. "limits.max_step.x_mm"
  std::string value;  // the offending value as TOML text
  std::string reason;
  int line = 0;       // the key's line in the file, 0 when not given
};

MachineConfig parse_machine_config(const std::string& toml_text, const std::string& source_name);
MachineConfig read_machine_config(const std::filesystem::path& path);

}  // namespace alc::nc
