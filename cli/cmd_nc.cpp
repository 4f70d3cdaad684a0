// alc nc: NC commands (JSON lines) in, NC code out, through the safety limits of the machine config.
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <variant>
#include <vector>

#include "commands.hpp"
#include "common/input_file.hpp"
#include "nc_interface/dialects.hpp"
#include "nc_interface/jsonl.hpp"
#include "nc_interface/machine_config.hpp"
#include "nc_interface/recorder.hpp"
#include "nc_interface/transports.hpp"

namespace alc::cli {
namespace {

struct NcArgs {
  std::string dialect;
  std::string machine;
  std::string input;
  std::string in_force;  // JSON lines of the offsets in force now, "" = zero offsets
  std::string sink = "stdout";
  std::string spool_dir;
  int port = 5007;
  bool port_given = false;
};

// The offsets in force now: axis_offsets lines, at most one per work offset (a line without one: the
// machine config's [nc] work_offset, as for the commands). A work offset without a line is taken as
// zero offsets.
std::vector<nc::AxisOffsets> read_in_force(const std::string& path, int default_work_offset) {
  if (const std::string problem = io::input_file_problem(path); !problem.empty())
    throw UsageError("--in-force " + path + ": " + problem);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UsageError("--in-force: cannot open " + path + ": " + std::strerror(errno));
  std::vector<nc::NcCommand> lines;
  std::vector<std::size_t> at;  // each entry's line in the file (before: "entry 1", counted without blank lines)
  try {
    lines = nc::read_commands_jsonl(in, path, default_work_offset, &at);
  } catch (const nc::JsonlError& e) {
    throw UsageError(std::string("--in-force: ") + e.what());
  }
  std::vector<nc::AxisOffsets> out;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string where = "--in-force " + path + ":" + std::to_string(at[i]) + ": ";
    const auto* o = std::get_if<nc::AxisOffsets>(&lines[i]);
    if (!o) throw UsageError(where + "not an axis_offsets line (the offsets in force are axis_offsets lines only)");
    for (std::size_t k = 0; k < out.size(); ++k)
      if (out[k].work_offset == o->work_offset)
        throw UsageError(where + nc::work_offset_name(o->work_offset) + " is given twice (first on line " +
                         std::to_string(at[k]) + ")");
    out.push_back(*o);
  }
  return out;
}

void run_nc(const NcArgs& args) {
  const auto dialect = nc::parse_dialect(args.dialect);
  if (!dialect) throw UsageError("--dialect must be linuxcnc, fanuc, sinumerik or heidenhain, got '" + args.dialect + "'");
  if (args.sink == "linuxcncrsh" && *dialect != nc::Dialect::LinuxCNC)
    throw UsageError("--sink linuxcncrsh needs --dialect linuxcnc");
  if (args.sink == "spool" && args.spool_dir.empty()) throw UsageError("--sink spool needs --spool-dir DIR");
  // An option of another sink would be ignored: `--spool-dir DIR` alone wrote the program to stdout,
  // and a DNC script that forgot --sink delivered nothing, with exit 0.
  if (!args.spool_dir.empty() && args.sink != "spool")
    throw UsageError("--spool-dir is for --sink spool; with --sink " + args.sink +
                     " it would be ignored (give --sink spool, or leave --spool-dir out)");
  if (args.port_given && args.sink != "linuxcncrsh")
    throw UsageError("--port is for --sink linuxcncrsh; with --sink " + args.sink +
                     " it would be ignored (give --sink linuxcncrsh, or leave --port out)");
  nc::MachineConfig config;
  if (!args.machine.empty()) {
    try {
      config = nc::read_machine_config(args.machine);
    } catch (const nc::ConfigError& e) {
      throw UsageError(e.what());
    }
  }
  std::vector<nc::NcCommand> commands;
  try {
    if (args.input.empty() || args.input == "-") {
      commands = nc::read_commands_jsonl(std::cin, "<stdin>", config.work_offset);
    } else {
      if (const std::string problem = io::input_file_problem(args.input); !problem.empty())
        throw UsageError("--in " + args.input + ": " + problem);
      std::ifstream in(args.input, std::ios::binary);
      if (!in) throw UsageError("--in: cannot open " + args.input + ": " + std::strerror(errno));
      commands = nc::read_commands_jsonl(in, args.input, config.work_offset);
    }
  } catch (const nc::JsonlError& e) {
    throw UsageError(e.what());
  }
  // A work offset that G10 L2 would replace needs its base, for every axis the command writes
  // (docs/nc.md, "Base offsets").
  for (std::size_t i = 0; i < commands.size(); ++i)
    if (const auto* o = std::get_if<nc::AxisOffsets>(&commands[i]))
      if (const std::string why = nc::missing_base(*dialect, config.nc, o->work_offset,
                                                   o->a_deg ? 'A' : o->b_deg ? 'B' : '\0');
          !why.empty())
        throw UsageError("command " + std::to_string(i + 1) + ": " + why +
                         (args.machine.empty() ? "; give --machine FILE" : " in " + args.machine));
  // Safety first: nothing is written when any command is refused. max_step is judged from the
  // offsets in force (--in-force), else from zero offsets, per register of the dialect (heidenhain:
  // one datum shift for every work offset).
  nc::CommandRecorder recorder = nc::recorder_for(*dialect, config.limits);
  if (!args.in_force.empty()) {
    for (const nc::AxisOffsets& o : read_in_force(args.in_force, config.work_offset)) {
      try {
        recorder.set_in_force(o);
      } catch (const std::invalid_argument& e) {
        throw UsageError("--in-force " + args.in_force + ": " + e.what());
      }
    }
  }
  std::size_t refused = 0;
  for (std::size_t i = 0; i < commands.size(); ++i) {
    const nc::SafetyDecision d = recorder.record(commands[i]);
    if (d.verdict == nc::SafetyVerdict::Accepted) continue;
    std::cerr << "alc nc: command " << i + 1 << ": " << d.message << "\n";
    if (d.verdict == nc::SafetyVerdict::Refused) ++refused;
  }
  if (refused > 0) throw std::runtime_error(std::to_string(refused) + " command(s) refused by the safety limits; nothing written");
  if (args.sink == "stdout") {
    std::cout << nc::write_program(*dialect, recorder.to_send(), config.nc);
    std::cout.flush();
    if (!std::cout) throw std::runtime_error("cannot write to stdout");
    return;
  }
  std::unique_ptr<nc::Sink> sink;
  if (args.sink == "spool") {
    sink = std::make_unique<nc::SpoolSink>(args.spool_dir, *dialect, config.nc);
  } else {
    nc::LinuxcncrshOptions options;
    options.port = args.port;
    sink = std::make_unique<nc::LinuxcncrshSink>(options, config.nc);
  }
  nc::CommandQueue queue;
  for (const nc::NcCommand& c : recorder.to_send()) queue.push(c);
  const nc::DeliveryReport report = queue.flush(*sink);
  if (!report.ok()) {
    // Nothing is lost: the commands not delivered go to stderr as JSON lines, ready to resend.
    std::cerr << "alc nc: " << report.delivered << " delivered, " << report.pending << " not delivered:\n";
    for (const nc::NcCommand& c : queue.pending()) std::cerr << nc::to_json_line(c) << "\n";
    throw std::runtime_error(report.error);
  }
  std::cerr << "alc nc: " << report.delivered << " command(s) delivered to " << sink->name() << "\n";
}

}  // namespace

void add_nc_command(CLI::App& app) {
  auto args = std::make_shared<NcArgs>();
  CLI::App* cmd = app.add_subcommand(
      "nc", "Turn NC commands (JSON lines: axis_offsets, probe_interval) into NC code of one dialect.\n"
            "Reads stdin (or --in), checks the machine's safety limits, writes to stdout, a spool\n"
            "directory, or a running LinuxCNC (linuxcncrsh, localhost only). max_step is judged against\n"
            "the offsets in force given by --in-force; without it, the first command of each work offset\n"
            "is judged against zero offsets. See docs/nc.md.");
  cmd->add_option("--dialect", args->dialect, "linuxcnc, fanuc, sinumerik or heidenhain")->required();
  cmd->add_option("--machine", args->machine,
                  "machine config (TOML): [nc] (parameter numbers, base offsets) and [limits]; its [kinematics] "
                  "is not used (the commands are axis offsets already); see nc_interface/machine.example.toml");
  cmd->add_option("--in", args->input, "commands file (JSON lines); default stdin");
  cmd->add_option("--in-force", args->in_force,
                  "offsets in force now (JSON lines, one axis_offsets per work offset, same form as the commands); "
                  "the safety gate judges max_step from them. Without it (or for a work offset not listed) the "
                  "first command is judged against zero offsets");
  cmd->add_option("--sink", args->sink, "stdout (one program), spool (one file per command) or linuxcncrsh")
      ->check(CLI::IsMember({"stdout", "spool", "linuxcncrsh"}));
  cmd->add_option("--spool-dir", args->spool_dir, "directory for --sink spool");
  CLI::Option* port = add_whole_option(cmd, "--port", args->port, "linuxcncrsh port on localhost (default 5007)", 1, 65535);
  cmd->callback([args, port] {
    args->port_given = port->count() > 0;
    run_nc(*args);
  });
}

}  // namespace alc::cli
