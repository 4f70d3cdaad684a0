#pragma once
// NC commands as text in one of four dialects. What goes where, and why: docs/nc.md.
#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "nc_interface/commands.hpp"
#include "nc_interface/safety.hpp"

namespace alc::nc {

enum class Dialect { LinuxCNC, Fanuc, Sinumerik, Heidenhain };

// "linuxcnc", "fanuc", "sinumerik", "heidenhain" (exact, lower case).
std::optional<Dialect> parse_dialect(std::string_view text);
std::string_view dialect_name(Dialect dialect);
// File name extension of a program: ".ngc", ".nc", ".mpf", ".h".
std::string_view program_extension(Dialect dialect);
// Where the dialect's axis offsets land, for the safety gate: one register per work offset
// (linuxcnc, fanuc: G10 L2 P1…P6; sinumerik: $P_UIFR[1…6]), or one for all (heidenhain: every
// command is the same cycle 7 datum shift of the active preset; work_offset is not written).
OffsetRegisters offset_registers(Dialect dialect);

// The operator's own setting of a work offset. G10 L2 (LinuxCNC, Fanuc) sets the whole work offset,
// so those writers write base + compensation; Sinumerik (fine offset) and Heidenhain (datum shift)
// act on top of the base and do not need it.
struct BaseOffset {
  double x_mm = 0.0;  // [mm]
  double y_mm = 0.0;  // [mm]
  double z_mm = 0.0;  // [mm]
  double a_deg = 0.0; // [°]
  double b_deg = 0.0; // [°]
  double c_deg = 0.0; // [°]
  bool given = false; // written in the machine file ([nc.base.Gxx]); see missing_base()
  // Which axes the machine file's table gives, in X Y Z A B C order (a key left out would be written
  // as 0 by G10 L2), and the table's line in the file (0: not known). See missing_base().
  std::array<bool, 6> axes{};
  int line = 0;
};

// The command a program's header comment names as its writer (linuxcnc: "written by alc nc"); fixed
// text, never user input.
enum class ProgramWriter { AlcNc, AlcReplay, AlcSupervise };
// "alc nc", "alc replay", "alc supervise".
std::string_view program_writer_name(ProgramWriter writer);

struct DialectOptions {
  std::array<BaseOffset, 6> base{};            // index 0 = G54 … 5 = G59
  int linuxcnc_interval_parameter = 3001;      // #31…#5000; persistent only if listed in the var file
  int fanuc_interval_variable = 500;           // #500…#999 (retained common variables)
  int fanuc_program_number = 9100;             // O1…O9999
  int sinumerik_interval_r = 100;              // R0…R999 (retentive)
  int heidenhain_interval_qr = 100;            // QR0…QR499 (retentive)
  std::string heidenhain_program_name = "ALCCOMP";  // [A-Z0-9_], 1…16 characters
  ProgramWriter writer = ProgramWriter::AlcNc;  // named in the linuxcnc program's header comment
  // A comment line after the header of the programs that write a base (linuxcnc, fanuc), e.g. alc
  // replay's without --machine, written for the built-in twin whose work offsets are 0. Letters, digits,
  // spaces and , . : - only (it goes into a comment).
  std::string base_note;
};

// Empty if usable, else which option is out of range (names the option and the value).
std::string validate(const DialectOptions& options);
// Empty if `dialect` may write axis offsets to `work_offset` (1 = G54) on a machine, else why not:
// LinuxCNC and Fanuc write G10 L2, which replaces the whole work offset with base + compensation, so
// a base that is not given (a default of 0) would set the operator's work offset to the compensation
// alone (G54 X-350 Z-420 becoming X0.0083 Z0.006). That holds per axis: the table must give every
// axis the program writes, X, Y, Z, C and `tilt_axis` ('A' or 'B'; 0 for a program without a tilt
// word). The reason names the table ([nc.base.G54], with its line when known) and the keys missing.
// Sinumerik and Heidenhain add to the work offset: always empty.
std::string missing_base(Dialect dialect, const DialectOptions& options, int work_offset, char tilt_axis);
// Empty if the command can be written, else what is wrong (field and value).
std::string validate(const NcCommand& command);

// The NC program for `commands`, in order. Throws std::invalid_argument for invalid options or
// commands (nothing is written for a bad input), never produces a partial program.
std::string write_program(Dialect dialect, const std::vector<NcCommand>& commands, const DialectOptions& options = {});

// The LinuxCNC lines to send one by one as MDI commands (no comments, no program end).
std::vector<std::string> linuxcnc_mdi_lines(const NcCommand& command, const DialectOptions& options = {});

}  // namespace alc::nc
