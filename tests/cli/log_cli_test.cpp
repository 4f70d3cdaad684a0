// The global logging options of `alc`: --log-level, --log-file (rotating), for every command.
#include <catch2/catch.hpp>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "../cli_support.hpp"
#include "storage/history_writer.hpp"

namespace fs = std::filesystem;

namespace {

alc_test::CliRun run(const std::string& args) { return alc_test::run_alc(args, "log_cli_test"); }

// (Built with append: "'" + string trips GCC 12's -Wrestrict false positive.)
std::string quoted(const fs::path& p) { return std::string(1, '\'').append(p.string()).append(1, '\''); }

// An empty history (schema created, no runs) in the test's scratch directory.
fs::path empty_history() {
  const fs::path file = alc_test::work_dir("log_cli_test") / "history.sqlite";
  fs::remove(file);
  alc::storage::HistoryWriter writer(file);
  writer.close();
  return file;
}

void write(const fs::path& file, const std::string& text) {
  std::ofstream(file, std::ios::binary) << text;
}

}  // namespace

TEST_CASE("alc --log-level: an unknown level is a usage error naming it, before the command runs") {
  const auto r = run("--log-level nope simulate --list");
  CHECK(r.exit_code == 2);
  CHECK(r.out.empty());
  CHECK_THAT(r.err, Catch::Contains("'nope'") && Catch::Contains("--log-level"));
  // A level after the command is the command's (unknown) option, also a usage error.
  CHECK(run("simulate --list --log-level info").exit_code == 2);
  CHECK(run("--log-level info simulate --list").exit_code == 0);
}

TEST_CASE("alc --log-file: opening a history logs a [storage] line to the file at info, nothing at the default level") {
  const fs::path history = empty_history();
  const fs::path log = alc_test::work_dir("log_cli_test") / "alc.log";
  fs::remove(log);
  const auto r = run("--log-level info --log-file " + quoted(log) + " db info " + quoted(history));
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const std::string text = alc_test::slurp(log);
  CHECK_THAT(text, Catch::Contains("[info] [storage]") && Catch::Contains(history.string()));
  CHECK_THAT(r.err, Catch::Contains("[storage]"));  // stderr gets the line too

  fs::remove(log);
  const auto quiet = run("--log-file " + quoted(log) + " --log-max-bytes 4096 --log-max-files 2 db info " + quoted(history));
  CHECK(quiet.exit_code == 0);
  CHECK(alc_test::slurp(log).find("[storage]") == std::string::npos);  // warn by default
  CHECK(quiet.err.empty());
}

TEST_CASE("alc --log-file that is a file the command reads or writes is refused before anything is written to it") {
  const fs::path dir = alc_test::work_dir("log_cli_test");
  const fs::path history = empty_history();
  const std::string before = alc_test::slurp(history);
  // The history read (at info a [storage] line would be logged into it), under another spelling.
  auto r = run("--log-level info --log-file " + quoted(dir / "." / "history.sqlite") + " db info " + quoted(history));
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains("--log-file") && Catch::Contains("alc db info's FILE") &&
                        Catch::Contains("log lines would be written into it"));
  CHECK(r.out.empty());
  CHECK(alc_test::slurp(history) == before);
  // The -wal of a history that the replay would create: refused before the history exists.
  const fs::path made = dir / "made.sqlite";
  fs::remove(made);
  r = run("--log-file " + quoted(dir / "made.sqlite-wal") + " replay --case A --db " + quoted(made));
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains("alc replay's --db journal"));
  CHECK_FALSE(fs::exists(made));
  CHECK_FALSE(fs::exists(dir / "made.sqlite-wal"));
  // A name the log rotates to (FILE.1 ... FILE.N): the first rotation would rename the log over the history.
  r = run("--log-file " + quoted(dir / "made") + " --log-max-bytes 200 replay --case A --db " + quoted(dir / "made.1"));
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains("rotates to") && Catch::Contains("alc replay's --db"));
  CHECK_FALSE(fs::exists(dir / "made.1"));
  // Beyond the files kept, no rotation reaches it.
  r = run("--log-file " + quoted(dir / "made") + " --log-max-files 1 replay --case A --db " + quoted(dir / "made.2"));
  CHECK(r.exit_code == 0);
  fs::remove(dir / "made.2");
  fs::remove(dir / "made");
  // A log beside them is fine.
  CHECK(run("--log-file " + quoted(dir / "alc.log") + " db info " + quoted(history)).exit_code == 0);
}

TEST_CASE("alc supervise: a log (--log-file or [log] file) over a file its configuration names is refused") {
  // Refused before the broker is dialled (port 1 has none): the history named only inside the
  // configuration, its inbox and the configuration itself; the history keeps its bytes.
  const fs::path dir = alc_test::work_dir("log_cli_test") / "supervise";
  fs::remove_all(dir);
  fs::create_directories(dir);
  { alc::storage::HistoryWriter writer(dir / "h.sqlite"); writer.close(); }
  const std::string before = alc_test::slurp(dir / "h.sqlite");
  const std::string config = "machine_id = \"dmu-1\"\n[mqtt]\nhost = \"127.0.0.1\"\nport = 1\n"
                             "[signals]\ninputs = [\"T_ENV\"]\noutputs = [\"E_X0C\"]\n"
                             "[history]\ndb = \"h.sqlite\"\n";
  write(dir / "s.toml", config);
  const std::string toml = quoted(dir / "s.toml");
  auto r = run("--log-level info --log-file " + quoted(dir / "h.sqlite") + " supervise --config " + toml);
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains("--log-file '" + (dir / "h.sqlite").string() + "' is " + (dir / "s.toml").string() +
                                    "'s [history] db '" + (dir / "h.sqlite").string() + "' itself") &&
                        Catch::Contains("log lines would be written into it"));
  CHECK(alc_test::slurp(dir / "h.sqlite") == before);
  r = run("--log-file " + quoted(dir / "h.sqlite.inbox-wal") + " supervise --config " + toml);
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains("[history] db's inbox journal"));
  CHECK_FALSE(fs::exists(dir / "h.sqlite.inbox-wal"));
  // [log] file naming the configuration itself.
  const std::string own_log = config + "[log]\nfile = \"s5.toml\"\n";
  write(dir / "s5.toml", own_log);
  r = run("supervise --config " + quoted(dir / "s5.toml"));
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains("key 'log.file'") && Catch::Contains("is the configuration '"));
  CHECK(alc_test::slurp(dir / "s5.toml") == own_log);
  // A log rotating to the history: the rotation would rename the log over it.
  std::string renamed = config;
  renamed.replace(renamed.find("h.sqlite"), 8, "h.1");
  write(dir / "s1.toml", renamed);
  r = run("--log-file " + quoted(dir / "h") + " supervise --config " + quoted(dir / "s1.toml"));
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains("rotates to") && Catch::Contains("[history] db"));
  CHECK_FALSE(fs::exists(dir / "h.1"));
  // The configuration's own [log] file, relative to it: the key is named.
  write(dir / "s2.toml", config + "[log]\nfile = \"h.sqlite\"\n");
  r = run("supervise --config " + quoted(dir / "s2.toml"));
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains((dir / "s2.toml").string() + ": key 'log.file': [log] file '") &&
                        Catch::Contains("is [history] db '") && Catch::Contains("; choose another [log] file") &&
                        !Catch::Contains("file file"));
  CHECK(alc_test::slurp(dir / "h.sqlite") == before);
  // A log beside them passes this check: the supervisor then stops on the password file it cannot read
  // (before the broker), and says why in the log as it says every fatal error there.
  const std::string no_password = config + "[log]\nlevel = \"info\"\n";
  const auto with_user = [&](std::string text) {
    return text.replace(text.find("port = 1\n"), 9, "port = 1\nusername = \"alc\"\npassword_file = \"missing\"\n");
  };
  write(dir / "s3.toml", with_user(config));
  r = run("--log-file " + quoted(dir / "alc.log") + " supervise --config " + quoted(dir / "s3.toml"));
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains("key 'mqtt.password_file'"));
  CHECK_THAT(alc_test::slurp(dir / "alc.log"), Catch::Contains("[critical] [supervisor] stopped: ") &&
                                                   Catch::Contains("key 'mqtt.password_file'"));
  // [log] level alone keeps alc's --log-file (it was dropped: the log went to stderr only).
  fs::remove(dir / "alc.log");
  write(dir / "s4.toml", with_user(no_password));
  r = run("--log-file " + quoted(dir / "alc.log") + " supervise --config " + quoted(dir / "s4.toml"));
  CHECK(r.exit_code == 2);
  CHECK_THAT(alc_test::slurp(dir / "alc.log"), Catch::Contains("key 'mqtt.password_file'"));
  CHECK(alc_test::slurp(dir / "h.sqlite") == before);
}

TEST_CASE("alc --log-file supervise reads its configuration once: a pipe (--config /dev/stdin) is checked and run alike") {
  // `envsubst < s.toml | alc --log-file alc.log supervise --config /dev/stdin`: the pipe holds the
  // configuration once; a second reading gets nothing ("cannot be read" or an empty configuration). Read
  // once, the supervisor gets to the password file it cannot read (before the broker) and says so, in
  // the log too.
  const fs::path dir = alc_test::work_dir("log_cli_test") / "pipe";
  fs::remove_all(dir);
  fs::create_directories(dir);
  write(dir / "s.toml", "machine_id = \"dmu-1\"\n[mqtt]\nhost = \"127.0.0.1\"\nport = 1\nusername = \"alc\"\n"
                        "password_file = " + quoted(dir / "missing") + "\n[signals]\ninputs = [\"T_ENV\"]\n"
                        "outputs = [\"E_X0C\"]\n[history]\ndb = " + quoted(dir / "h.sqlite") + "\n");
  const std::string cmd = "cat " + quoted(dir / "s.toml") + " | \"" + ALC_CLI_PATH + "\" --log-file " +
                          quoted(dir / "alc.log") + " supervise --config /dev/stdin 2>" + quoted(dir / "err");
  const int status = std::system(cmd.c_str());
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 2);
  const std::string err = alc_test::slurp(dir / "err");
  CHECK_THAT(err, Catch::Contains("/dev/stdin: key 'mqtt.password_file'"));
  CHECK_THAT(alc_test::slurp(dir / "alc.log"), Catch::Contains("[critical] [supervisor] stopped: ") &&
                                                   Catch::Contains("key 'mqtt.password_file'"));
}

TEST_CASE("alc --log-file in a directory that does not exist fails naming the file") {
  const fs::path log = alc_test::work_dir("log_cli_test") / "no_such_dir" / "alc.log";
  fs::remove_all(log.parent_path());
  const auto r = run("--log-file " + quoted(log) + " simulate --list");
  CHECK(r.exit_code == 1);
  CHECK_THAT(r.err, Catch::Contains(log.string()));
  CHECK(r.out.empty());
}

TEST_CASE("alc --log-level info replay: the guard's decisions are logged with their output, the type named once") {
  const alc_test::CliRun r = run("--log-level info replay --case H5");
  REQUIRE(r.exit_code == 0);
  // e.g. "t = 37500 s: guard: E_Y0C: compensation gain 1 -> 0.8: on the recent probes ..."
  CHECK_THAT(r.err, Catch::Contains("s: guard: E_Y0C: compensation gain 1 -> 0.8: on the recent probes"));
  CHECK(r.err.find(": guard: guard") == std::string::npos);
  CHECK(r.err.find(": guard: E_Z0T: guard:") == std::string::npos);
}

TEST_CASE("alc --log-level info replay: every phase change is logged with its phases, also those a probe brings") {
  const alc_test::CliRun r = run("--log-level info replay --case C");
  REQUIRE(r.exit_code == 0);
  // The end of CP comes with a sample; a breach (Post-CP -> NG) and the update after NG with probes.
  CHECK_THAT(r.err, Catch::Contains("[info] [runtime] t = 23400 s: phase_change: CP -> Post-CP: calibration phase complete"));
  CHECK_THAT(r.err, Catch::Contains("s: phase_change: Post-CP -> NG: ACL breach on E_"));
  CHECK_THAT(r.err, Catch::Contains("s: phase_change: NG -> Post-CP: NG measurements complete"));
  const alc_test::CliRun quiet = run("replay --case C");
  CHECK(quiet.err.empty());
}
