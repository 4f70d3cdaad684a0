#include "nc_interface/dialects.hpp"

#include <cctype>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "common/number_text.hpp"

#include "nc_interface/nc_number.hpp"

namespace alc::nc {
namespace {

struct AxisWord {
  char letter;
  double value;  // [mm] or [°]
};

// The axis words of an offset command, in X Y Z A B C order; absent rotary axes are left out (the NC
// keeps their value). A base is added as printed (with_base).
std::vector<AxisWord> axis_words(const AxisOffsets& o, const BaseOffset* base) {
  const BaseOffset zero{};
  const BaseOffset& b = base ? *base : zero;
  std::vector<AxisWord> words{{'X', with_base(b.x_mm, o.x_mm)}, {'Y', with_base(b.y_mm, o.y_mm)},
                              {'Z', with_base(b.z_mm, o.z_mm)}};
  if (o.a_deg) words.push_back({'A', with_base(b.a_deg, *o.a_deg)});
  if (o.b_deg) words.push_back({'B', with_base(b.b_deg, *o.b_deg)});
  words.push_back({'C', with_base(b.c_deg, o.c_deg)});
  return words;
}

// The value written for an interval: minutes, or 0 for "never".
double interval_value(const ProbeInterval& p) { return p.minutes.value_or(0.0); }

std::string range_error(const std::string& name, long long value, long long lo, long long hi) {
  return name + " must be " + std::to_string(lo) + "…" + std::to_string(hi) + ", got " + std::to_string(value);
}

void check(Dialect, const std::vector<NcCommand>& commands, const DialectOptions& options) {
  if (const std::string e = validate(options); !e.empty()) throw std::invalid_argument(e);
  for (std::size_t i = 0; i < commands.size(); ++i)
    if (const std::string e = validate(commands[i]); !e.empty())
      throw std::invalid_argument("command " + std::to_string(i + 1) + ": " + e);
}

std::string n(double v) { return format_nc_number(v); }

void linuxcnc_lines(const NcCommand& command, const DialectOptions& options, std::vector<std::string>& out) {
  if (const auto* o = std::get_if<AxisOffsets>(&command)) {
    // G21 on the same line: G10 values are read in the active units, and ours are mm.
    std::string line = "G21 G10 L2 P" + std::to_string(o->work_offset);
    for (const AxisWord& w : axis_words(*o, &options.base[static_cast<std::size_t>(o->work_offset - 1)]))
      line += std::string(" ") + w.letter + n(w.value);
    out.push_back(line);
  } else {
    const auto& p = std::get<ProbeInterval>(command);
    std::string line = "#";
    line += std::to_string(options.linuxcnc_interval_parameter);
    out.push_back(line + " = " + n(interval_value(p)));
  }
}

void write_linuxcnc(std::ostream& s, const std::vector<NcCommand>& commands, const DialectOptions& options) {
  s << "(ALC thermal compensation, written by " << program_writer_name(options.writer)
    << ": work offsets G10 L2, probe interval #"
    << options.linuxcnc_interval_parameter << " [min])\n";
  if (!options.base_note.empty()) s << "(" << options.base_note << ")\n";
  std::vector<std::string> lines;
  for (const NcCommand& c : commands) linuxcnc_lines(c, options, lines);
  for (const std::string& l : lines) s << l << "\n";
  s << "M2\n";
}

void write_fanuc(std::ostream& s, const std::vector<NcCommand>& commands, const DialectOptions& options) {
  s << "%\n";
  s << "O" << options.fanuc_program_number << " (ALC THERMAL COMPENSATION)\n";
  if (!options.base_note.empty()) {
    std::string note = options.base_note;  // Fanuc comments: upper case
    for (char& ch : note) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    s << "(" << note << ")\n";
  }
  // Metric input: G10 values are read in the active input unit, and ours are mm. Fanuc wants G20/G21
  // in a block of its own at the start of the program, before any coordinate system is set.
  s << "G21\n";
  for (const NcCommand& c : commands) {
    if (const auto* o = std::get_if<AxisOffsets>(&c)) {
      // G90: in G91 a G10 L2 would add to the work offset instead of setting it.
      s << "G90 G10 L2 P" << o->work_offset;
      for (const AxisWord& w : axis_words(*o, &options.base[static_cast<std::size_t>(o->work_offset - 1)]))
        s << " " << w.letter << n(w.value);
      s << "\n";
    } else {
      s << "#" << options.fanuc_interval_variable << "=" << n(interval_value(std::get<ProbeInterval>(c))) << "\n";
    }
  }
  s << "M30\n%\n";
}

// The G code that selects settable frame $P_UIFR[n]: G54…G57 for n = 1…4, G505…G599 for n = 5…99.
std::string sinumerik_frame_selection(int frame) {
  std::string code = "G";  // (not "G" + …: GCC 12 -Wrestrict false positive)
  code += std::to_string(frame <= 4 ? 53 + frame : 500 + frame);
  return code;
}

void write_sinumerik(std::ostream& s, const std::vector<NcCommand>& commands, const DialectOptions& options) {
  s << "; ALC THERMAL COMPENSATION: FINE OFFSET OF SETTABLE FRAMES, PROBE INTERVAL R"
    << options.sinumerik_interval_r << " [MIN]\n";
  for (const NcCommand& c : commands) {
    if (const auto* o = std::get_if<AxisOffsets>(&c)) {
      // Settable frame n = $P_UIFR[n]: work offsets 1…4 (G54…G57) are selected by G54…G57, 5 and 6
      // (our G58, G59) by G505, G506: Sinumerik's G58/G59 are programmable axial offsets, not frames.
      // FI = fine offset, added to the operator's coarse offset TR, so the base stays untouched.
      for (const AxisWord& w : axis_words(*o, nullptr))
        s << "$P_UIFR[" << o->work_offset << "," << w.letter << ",FI]=" << n(w.value) << "\n";
      // A changed settable frame becomes active only when it is selected again.
      s << sinumerik_frame_selection(o->work_offset) << "\n";
    } else {
      s << "R" << options.sinumerik_interval_r << "=" << n(interval_value(std::get<ProbeInterval>(c))) << "\n";
    }
  }
  s << "M30\n";
}

void write_heidenhain(std::ostream& s, const std::vector<NcCommand>& commands, const DialectOptions& options) {
  int block = 0;
  auto line = [&](const std::string& text) { s << block++ << " " << text << "\n"; };
  line("BEGIN PGM " + options.heidenhain_program_name + " MM");
  line("; ALC THERMAL COMPENSATION: DATUM SHIFT CYCLE 7, PROBE INTERVAL QR" +
       std::to_string(options.heidenhain_interval_qr) + " [MIN]");
  for (const NcCommand& c : commands) {
    if (const auto* o = std::get_if<AxisOffsets>(&c)) {
      // Cycle 7 shifts the datum against the active preset: compensation only, no base. There is one
      // such shift, so work_offset is not written: every command lands in the same register, and the
      // safety gate judges it so (offset_registers).
      line("CYCL DEF 7.0 DATUM SHIFT");
      int sub = 1;
      for (const AxisWord& w : axis_words(*o, nullptr))
        line("CYCL DEF 7." + std::to_string(sub++) + " " + w.letter + format_nc_number(w.value, SignStyle::Always));
    } else {
      line("FN 0: QR" + std::to_string(options.heidenhain_interval_qr) + " = " +
           format_nc_number(interval_value(std::get<ProbeInterval>(c)), SignStyle::Always));
    }
  }
  line("END PGM " + options.heidenhain_program_name + " MM");
}

bool finite_or_empty(const std::optional<double>& v) { return !v || std::isfinite(*v); }

}  // namespace

std::optional<Dialect> parse_dialect(std::string_view text) {
  for (Dialect d : {Dialect::LinuxCNC, Dialect::Fanuc, Dialect::Sinumerik, Dialect::Heidenhain})
    if (text == dialect_name(d)) return d;
  return std::nullopt;
}

std::string_view dialect_name(Dialect dialect) {
  switch (dialect) {
    case Dialect::LinuxCNC: return "linuxcnc";
    case Dialect::Fanuc: return "fanuc";
    case Dialect::Sinumerik: return "sinumerik";
    case Dialect::Heidenhain: return "heidenhain";
  }
  return "?";
}

std::string_view program_writer_name(ProgramWriter writer) {
  switch (writer) {
    case ProgramWriter::AlcNc: return "alc nc";
    case ProgramWriter::AlcReplay: return "alc replay";
    case ProgramWriter::AlcSupervise: return "alc supervise";
  }
  return "alc";
}

std::string_view program_extension(Dialect dialect) {
  switch (dialect) {
    case Dialect::LinuxCNC: return ".ngc";
    case Dialect::Fanuc: return ".nc";
    case Dialect::Sinumerik: return ".mpf";
    case Dialect::Heidenhain: return ".h";
  }
  return ".txt";
}

OffsetRegisters offset_registers(Dialect dialect) {
  return dialect == Dialect::Heidenhain ? OffsetRegisters::Single : OffsetRegisters::PerWorkOffset;
}

std::string validate(const DialectOptions& o) {
  if (o.linuxcnc_interval_parameter < 31 || o.linuxcnc_interval_parameter > 5000)
    return range_error("linuxcnc_interval_parameter", o.linuxcnc_interval_parameter, 31, 5000);
  if (o.fanuc_interval_variable < 500 || o.fanuc_interval_variable > 999)
    return range_error("fanuc_interval_variable", o.fanuc_interval_variable, 500, 999);
  if (o.fanuc_program_number < 1 || o.fanuc_program_number > 9999)
    return range_error("fanuc_program_number", o.fanuc_program_number, 1, 9999);
  if (o.sinumerik_interval_r < 0 || o.sinumerik_interval_r > 999)
    return range_error("sinumerik_interval_r", o.sinumerik_interval_r, 0, 999);
  if (o.heidenhain_interval_qr < 0 || o.heidenhain_interval_qr > 499)
    return range_error("heidenhain_interval_qr", o.heidenhain_interval_qr, 0, 499);
  const std::string& name = o.heidenhain_program_name;
  bool name_ok = !name.empty() && name.size() <= 16;
  for (char ch : name) name_ok = name_ok && (std::isupper(static_cast<unsigned char>(ch)) ||
                                             std::isdigit(static_cast<unsigned char>(ch)) || ch == '_');
  if (!name_ok) return "heidenhain_program_name must be 1…16 of A-Z, 0-9, _; got '" + name + "'";
  for (std::size_t i = 0; i < o.base.size(); ++i) {
    const BaseOffset& b = o.base[i];
    for (double v : {b.x_mm, b.y_mm, b.z_mm, b.a_deg, b.b_deg, b.c_deg})
      if (!std::isfinite(v) || std::abs(v) > kMaxBase)
        return "base offset of " + work_offset_name(static_cast<int>(i) + 1) +
               " must be finite and within ±1e5 (with the compensation it must print within ±1e6), got " +
               common::shortest_text(v);
  }
  return {};
}

std::string missing_base(Dialect dialect, const DialectOptions& options, int work_offset, char tilt_axis) {
  if (dialect != Dialect::LinuxCNC && dialect != Dialect::Fanuc) return {};
  if (work_offset < kMinWorkOffset || work_offset > kMaxWorkOffset) return {};  // validate() says so
  const BaseOffset& b = options.base[static_cast<std::size_t>(work_offset - 1)];
  const std::string wo = work_offset_name(work_offset);
  const std::string writer = std::string(dialect == Dialect::LinuxCNC ? "linuxcnc" : "fanuc") +
                             " writes G10 L2, which replaces the whole " + wo + " with base + compensation";
  // The axes the program writes: X Y Z, the tilt axis (if any), C; index into BaseOffset::axes.
  std::vector<std::pair<std::size_t, const char*>> written{{0, "x_mm"}, {1, "y_mm"}, {2, "z_mm"}};
  if (tilt_axis == 'A') written.emplace_back(3, "a_deg");
  if (tilt_axis == 'B') written.emplace_back(4, "b_deg");
  written.emplace_back(5, "c_deg");
  std::string keys;
  for (const auto& [index, key] : written) keys += std::string(keys.empty() ? "" : ", ") + key;
  if (!b.given)
    return writer + ", and the machine file gives no base for it: the operator's " + wo +
           " would become the compensation alone. Write the work offset without compensation as [nc.base." + wo +
           "] (" + keys + "; 0 only where " + wo + " really is 0)";
  std::string missing, letters;
  for (const auto& [index, key] : written) {
    if (b.axes[index]) continue;
    missing += std::string(missing.empty() ? "" : ", ") + "'nc.base." + wo + "." + key + "'";
    letters += std::string(letters.empty() ? "" : ", ") + "XYZABC"[index];
  }
  if (missing.empty()) return {};
  return "[nc.base." + wo + "]" + (b.line > 0 ? " (line " + std::to_string(b.line) + ")" : std::string()) +
         " lacks key " + missing + ": " + writer + ", so " + wo + " " + letters +
         " would become the compensation alone, not the operator's value. Give every axis the program writes (" +
         keys + "; 0 only where " + wo + " really is 0)";
}

std::string validate(const NcCommand& command) {
  if (const auto* o = std::get_if<AxisOffsets>(&command)) {
    if (o->work_offset < kMinWorkOffset || o->work_offset > kMaxWorkOffset)
      return "work_offset must be 1 (G54) … 6 (G59), got " + std::to_string(o->work_offset);
    if (o->a_deg && o->b_deg) return "a_deg and b_deg are both set; a table-table machine has one tilt axis";
    const std::pair<const char*, std::optional<double>> fields[] = {
        {"x_mm", o->x_mm}, {"y_mm", o->y_mm}, {"z_mm", o->z_mm}, {"a_deg", o->a_deg}, {"b_deg", o->b_deg},
        {"c_deg", o->c_deg}};
    for (const auto& [name, value] : fields)
      if (value && (!std::isfinite(*value) || std::abs(*value) > kMaxNcMagnitude))
        return std::string(name) + " must be finite and within ±1e6, got " + common::shortest_text(*value);
    if (!finite_or_empty(o->time_s)) return "time_s must be finite";
    if (const auto& r = o->non_compensable_um_per_m; r && (!std::isfinite(*r) || *r < 0.0 || *r > kMaxNcMagnitude))
      return "non_compensable_um_per_m must be >= 0, finite and within 1e6, got " + common::shortest_text(*r);
    return {};
  }
  const auto& p = std::get<ProbeInterval>(command);
  if (p.minutes && (!std::isfinite(*p.minutes) || *p.minutes <= 0.0 || *p.minutes > kMaxNcMagnitude))
    return "minutes must be > 0 and finite (null for never), got " + common::shortest_text(*p.minutes);
  // 0.0001 min is the NC resolution: a smaller interval would be written as 0 = never.
  if (p.minutes && std::llround(*p.minutes * 1e4) == 0)
    return "minutes must be at least 0.0001 (0 in the NC means never), got " + common::shortest_text(*p.minutes);
  if (!finite_or_empty(p.time_s)) return "time_s must be finite";
  return {};
}

std::string write_program(Dialect dialect, const std::vector<NcCommand>& commands, const DialectOptions& options) {
  check(dialect, commands, options);
  std::ostringstream s;
  switch (dialect) {
    case Dialect::LinuxCNC: write_linuxcnc(s, commands, options); break;
    case Dialect::Fanuc: write_fanuc(s, commands, options); break;
    case Dialect::Sinumerik: write_sinumerik(s, commands, options); break;
    case Dialect::Heidenhain: write_heidenhain(s, commands, options); break;
  }
  return s.str();
}

std::vector<std::string> linuxcnc_mdi_lines(const NcCommand& command, const DialectOptions& options) {
  check(Dialect::LinuxCNC, {command}, options);
  std::vector<std::string> lines;
  linuxcnc_lines(command, options, lines);
  return lines;
}

}  // namespace alc::nc
