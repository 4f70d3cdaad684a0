// The supervisor in process (no broker) against messages whose time is wrong: a sample far ahead of
// the others, a probe result long after its timeout, a probe that is never answered, samples far
// denser than their clock says. None may stall the loop or refuse every later message. And the
// history's retention, which keeps a run of months bounded on disk.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <optional>

#include "common/number_text.hpp"
#include "storage/history_reader.hpp"
#include "supervisor/config.hpp"
#include "supervisor/supervisor.hpp"
#include "supervisor_test_support.hpp"

using namespace alc;
using namespace alc::supervisor_test;

namespace {

// Case A's first hours with a short CP (probes every 15 min during it), an in-process supervisor.
struct Rig {
  scenarios::Scenario s;
  fs::path dir;
  supervisor::SupervisorConfig config;
  RecordingBus bus;
  Rig(const std::string& name, double hours, const std::string& history_extra = "", const std::string& controller_extra = "")
      : s(case_a(hours)), dir(temp_dir(name)) {
    std::string text = case_config(s, 1);
    const std::string cp = "cp = 6.5\ninterval = 2\n";
    text.replace(text.find(cp), cp.size(), "cp = 2\ncp-interval = 15\ninterval = 1\n" + controller_extra);
    const std::string snapshots = "snapshot_every_h = 2\n";
    text.replace(text.find(snapshots), snapshots.size(), snapshots + history_extra);
    // probe_timeout_s of case_config is a day: 30 min here.
    text.replace(text.find("probe_timeout_s = 86400"), 23, "probe_timeout_s = 1800");
    write(dir / "s.toml", text);
    config = supervisor::read_supervisor_config(dir / "s.toml");
  }
  std::string sample(std::size_t row, double shift_s = 0.0) const {
    Json j = Json::parse(sample_json(s, row));
    j["time_s"] = s.time_s[row] + shift_s;
    return j.dump();
  }
  std::string result(std::int64_t id, double time_s) const {
    return Json{{"id", id}, {"time_s", time_s}, {"errors", Json{{"E_X0C", 1.0}}}}.dump();
  }
};

}  // namespace

TEST_CASE("supervisor: a probe request says from and until when a result is taken, not only when it was due") {
  // Samples every 20 min, probes every 15 min in CP: a request goes out at the first sample after its due
  // time. Before, the payload held due_s alone, and a gateway stamping its result with it was rejected
  // ("before its request") every time, so CP never got a model.
  Rig rig("request-times", 3.0);
  supervisor::Supervisor sup(rig.config, rig.bus, "test");
  std::int64_t answered = 0;
  int checked = 0;
  for (std::size_t row = 0; row < rig.s.samples(); row += 20) {
    sup.on_message("sample", rig.sample(row), 0.0);
    const Json request = rig.bus.last("probe/request");
    if (request.is_null() || request["id"].get<std::int64_t>() == answered) continue;
    answered = request["id"].get<std::int64_t>();
    const double due = request["due_s"].get<double>(), requested = request["requested_s"].get<double>();
    CHECK(requested == rig.s.time_s[row]);
    CHECK(request["timeout_s"].get<double>() == rig.s.time_s[row] + 1800.0);
    if (requested > due) {
      ++checked;
      const auto rejected = sup.counts().rejected;
      sup.on_message("probe/result", rig.result(answered, due), 0.0);
      CHECK(sup.counts().rejected == rejected + 1);
      CHECK_THAT(rig.bus.last_event("MessageRejected").value("reason", ""),
                 Catch::Contains("is before its request at " + common::shortest_text(requested) +
                                 " s (the request's requested_s)"));
    }
    const auto rejected = sup.counts().rejected;
    sup.on_message("probe/result", rig.result(answered, requested), 0.0);
    CHECK(sup.counts().rejected == rejected);
  }
  CHECK(checked >= 3);
  CHECK(sup.counts().timeouts == 0);
  CHECK(sup.controller().state().probe_cycles == answered);  // every result learned
  CHECK(std::isfinite(sup.controller().state().cp_end_s));   // CP (2 h) ended
}

TEST_CASE("supervisor: a sample far ahead counts once the next confirms it, a typo like 1e15 is set aside") {
  Rig rig("time-jump", 2.0);
  supervisor::Supervisor sup(rig.config, rig.bus, "test");
  for (std::size_t row = 0; row < 40; ++row) sup.on_message("sample", rig.sample(row), 0.0);
  const auto received = sup.counts().received;
  REQUIRE(received == 40);
  // A sample at 1e15 s: held, then the next real one does not confirm it. Before, every later sample
  // was "time goes backwards" for ever.
  Json typo = Json::parse(rig.sample(40));
  typo["time_s"] = 1e15;
  sup.on_message("sample", typo.dump(), 0.0);
  CHECK(rig.bus.count("TimeJump") == 1);
  CHECK(sup.counts().received == 40);
  for (std::size_t row = 40; row < 60; ++row) sup.on_message("sample", rig.sample(row), 0.0);
  CHECK(sup.counts().received == 60);
  const Json rejected = rig.bus.last_event("MessageRejected");
  // Times in the shortest text that reads back (before: std::to_string's "1000000000000000.000000 s from
  // 2340.000000 s").
  CHECK_THAT(rejected.value("reason", ""), Catch::Contains("time jumps ahead to time_s = 1e+15 s from 2340 s and the "
                                                           "next sample (time_s = 2400 s) does not confirm it: set aside"));
  // A real gap (the machine off for a day): the sample after it confirms it, both count.
  const double day = 86400.0;
  for (std::size_t row = 60; row < 80; ++row) sup.on_message("sample", rig.sample(row, day), 0.0);
  CHECK(rig.bus.count("TimeJump") == 2);
  CHECK(sup.counts().received == 80);
  CHECK(sup.counts().rejected == 1);  // the typo alone
}

TEST_CASE("supervisor: a sample far ahead still held when the process is killed is held again after the restart") {
  // A real gap (the machine off for a day) whose first sample arrives, then kill -9 before the next:
  // before, the held sample lived in memory only (the broker had it acknowledged), and after the
  // restart the next sample was a jump of its own (a second TimeJump), the first one lost.
  Rig rig("jump-kill", 2.0);
  const double day = 86400.0;
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    RecordingBus bus;
    supervisor::Supervisor sup(rig.config, bus, "test");
    for (std::size_t row = 0; row < 40; ++row) sup.on_message("sample", rig.sample(row), 0.0);
    sup.on_message("sample", rig.sample(40, day), 0.0);
    ::_exit(bus.count("TimeJump") == 1 && sup.counts().received == 40 ? 0 : 3);
  }
  int status = 0;
  REQUIRE(::waitpid(child, &status, 0) == child);
  REQUIRE(WIFEXITED(status));  // _exit: no destructor ran, nothing stopped, as after kill -9
  REQUIRE(WEXITSTATUS(status) == 0);
  {
    supervisor::Supervisor sup(rig.config, rig.bus, "test");
    CHECK(sup.counts().received == 40);
    sup.on_message("sample", rig.sample(41, day), 0.0);  // confirms the gap: both count
    CHECK(sup.counts().received == 42);
    CHECK(rig.bus.count("TimeJump") == 0);  // the restart's recovery is muted; no new jump
    CHECK(sup.counts().rejected == 0);
    sup.stop();
  }
  const storage::HistoryReader r(rig.dir / "h.sqlite");
  const auto samples = r.input_samples(r.runs().back().run_id);
  bool stored = false;
  for (const auto& x : samples) stored = stored || x.time_s == rig.s.time_s[40] + day;
  CHECK(stored);
}

TEST_CASE("supervisor: a sample far ahead held while samples wait for a probe result survives the snapshot the result brings") {
  // Samples held behind an outstanding probe, then a jump: the result drained the held samples, the
  // consistent point after them saved a snapshot and pruned the inbox up to the result's entry, the
  // jump's among them. After a restart (a clean one too) the jump was gone: the sample confirming it was
  // held as a jump of its own, the accepted sample lost.
  Rig rig("jump-prune", 3.0);
  rig.config.history.snapshot_every_s = 36.0;  // a snapshot at every consistent point
  const double day = 86400.0;
  std::size_t row = 0;
  std::int64_t id = 0;
  double requested = 0.0;
  {
    supervisor::Supervisor sup(rig.config, rig.bus, "test");
    for (; row < 40 && id == 0; ++row) {
      sup.on_message("sample", rig.sample(row), 0.0);
      const Json request = rig.bus.last("probe/request");
      if (!request.is_null()) {
        id = request["id"].get<std::int64_t>();
        requested = request["requested_s"].get<double>();
      }
    }
    REQUIRE(id > 0);
    sup.on_message("sample", rig.sample(row++), 0.0);  // held: the probe is out
    sup.on_message("sample", rig.sample(row++), 0.0);
    sup.on_message("sample", rig.sample(row, day), 0.0);  // the machine was off for a day
    REQUIRE(rig.bus.count("TimeJump") == 1);
    sup.on_message("probe/result", rig.result(id, requested), 0.0);
    REQUIRE(sup.controller().state().probe_cycles == 1);
    CHECK(sup.counts().received == static_cast<std::int64_t>(row));
    sup.stop();
  }
  supervisor::Supervisor sup(rig.config, rig.bus, "test");
  CHECK(sup.counts().received == static_cast<std::int64_t>(row));
  sup.on_message("sample", rig.sample(row + 1, day), 0.0);  // confirms the gap: both count
  CHECK(sup.counts().received == static_cast<std::int64_t>(row + 2));
  CHECK(rig.bus.count("TimeJump") == 1);  // no second jump
  CHECK(sup.counts().rejected == 0);
  sup.stop();
}

TEST_CASE("supervisor: probe/now asks for a probe at the next sample, waits behind one outstanding, and survives kill -9") {
  // Someone who knows what no input shows (the machine was moved, relevelled) asks for a probe.
  Rig rig("probe-now", 5.0);
  rig.config.history.snapshot_every_s = 36.0;  // a snapshot at every consistent point
  std::size_t row = 0;
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    RecordingBus bus;
    supervisor::Supervisor sup(rig.config, bus, "test");
    int failed = 0;
    const auto expect = [&failed](bool ok, int code) { failed = failed ? failed : (ok ? 0 : code); };
    // Before the first sample there is nothing to probe against.
    sup.on_message("probe/now", R"({"reason": "too early"})", 0.0);
    expect(sup.counts().rejected == 1, 10);
    expect(bus.last_event("MessageRejected").value("reason", "").find("no sample has been received yet") !=
               std::string::npos, 11);
    // CP (2 h) and the first probes after it, each request answered at once.
    std::int64_t answered = 0;
    for (; rig.s.time_s[row] < rig.s.time_s[0] + 2.75 * 3600.0; ++row) {
      sup.on_message("sample", rig.sample(row), 0.0);
      const Json request = bus.last("probe/request");
      if (!request.is_null() && request["id"].get<std::int64_t>() > answered) {
        answered = request["id"].get<std::int64_t>();
        sup.on_message("probe/result", rig.result(answered, rig.s.time_s[row]), 0.0);
      }
    }
    const ControllerState& c = sup.controller().state();
    expect(c.phase == Phase::PostCalibration && c.next_probe_due_s > c.now_s + 600.0, 12);
    // Asked right after the snapshot of the latest sample, then killed before the next sample: before,
    // the live run asked at once and the restart at the next sample (another time, an id reused).
    sup.on_message("probe/now", R"({"reason": "relevelled"})", 0.0);
    expect(bus.last("probe/request")["id"].get<std::int64_t>() == answered, 13);  // none yet
    ::_exit(failed);  // no destructor, nothing stopped: as after kill -9
  }
  int status = 0;
  REQUIRE(::waitpid(child, &status, 0) == child);
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);
  supervisor::Supervisor sup(rig.config, rig.bus, "test");
  const auto rejected = sup.counts().rejected;
  const auto requests = sup.counts().requests;
  row = static_cast<std::size_t>(sup.controller().state().samples);
  REQUIRE(sup.controller().state().now_s == rig.s.time_s[row - 1]);
  REQUIRE(rig.bus.last("probe/request").is_null());
  CHECK(Json::parse(sup.state_json(true))["probe_asked"] == "relevelled");  // waiting, as the state says
  // The next sample asks, with the reason, at its own time.
  sup.on_message("sample", rig.sample(row), 0.0);
  const Json first = rig.bus.last("probe/request");
  REQUIRE_FALSE(first.is_null());
  CHECK(sup.counts().requests == requests + 1);
  CHECK(first["requested_s"].get<double>() == rig.s.time_s[row]);
  CHECK(rig.bus.last_event("probe_interval").value("reason", "") == "probe requested: relevelled");
  CHECK(Json::parse(sup.state_json(true))["probe_asked"].is_null());
  ++row;
  // A second while that probe is out waits for it; a third while the second waits is refused.
  sup.on_message("probe/now", R"({"reason": "and repaired"})", 0.0);
  sup.on_message("sample", rig.sample(row++), 0.0);  // held: the probe is out
  CHECK(sup.counts().requests == requests + 1);
  sup.on_message("probe/now", R"({"reason": "third"})", 0.0);
  CHECK(sup.counts().rejected == rejected + 1);
  CHECK(rig.bus.last_event("MessageRejected").value("reason", "") ==
        "a probe asked for on probe/now waits already (and repaired)");
  // The result drains the held sample; the waiting one is asked at the next sample fed after it.
  const int probes = sup.controller().state().probe_cycles;
  sup.on_message("probe/result", rig.result(first["id"].get<std::int64_t>(), first["requested_s"].get<double>()), 0.0);
  CHECK(sup.controller().state().probe_cycles == probes + 1);
  const Json second = rig.bus.last("probe/request");
  CHECK(second["id"].get<std::int64_t>() == first["id"].get<std::int64_t>() + 1);
  CHECK(second["requested_s"].get<double>() == rig.s.time_s[row - 1]);
  CHECK(rig.bus.last_event("probe_interval").value("reason", "") == "probe requested: and repaired");
  sup.stop();
  // The history holds each request once.
  const storage::HistoryReader r(rig.dir / "h.sqlite");
  int relevelled = 0, repaired = 0;
  for (const auto& x : r.probe_interval_changes(r.runs().back().run_id)) {
    relevelled += x.reason == "probe requested: relevelled";
    repaired += x.reason == "probe requested: and repaired";
  }
  CHECK(relevelled == 1);
  CHECK(repaired == 1);
}

TEST_CASE("supervisor: durability power makes the inbox commit with an fsync as the history does") {
  // Before, the inbox committed with synchronous=NORMAL whatever the durability: a power loss could lose
  // a sample the broker had been told was taken.
  for (const bool power : {false, true}) {
    Rig rig(power ? "inbox-power" : "inbox-process", 1.0, power ? "durability = \"power\"\n" : "");
    REQUIRE((rig.config.history.durability == storage::Durability::Power) == power);
    supervisor::Supervisor sup(rig.config, rig.bus, "test");
    CHECK(sup.inbox().synchronous() == (power ? 2 : 1));
    sup.stop();
  }
}

TEST_CASE("supervisor: a probe never answered times out once, the next request is judged from when it is asked") {
  Rig rig("probe-skip", 8.0);
  supervisor::Supervisor sup(rig.config, rig.bus, "test");
  // The gateway answers each request two samples after it came, measured then, but never probe 3.
  std::int64_t asked = 0;
  std::size_t asked_row = 0;
  std::int64_t learned = 0;
  for (std::size_t row = 0; row < rig.s.samples(); ++row) {
    sup.on_message("sample", rig.sample(row), 0.0);
    const Json request = rig.bus.last("probe/request");
    if (!request.is_null() && request["id"].get<std::int64_t>() > asked) {
      asked = request["id"].get<std::int64_t>();
      asked_row = row;
    }
    if (asked > learned && row == asked_row + 2) {
      learned = asked;
      if (asked != 3) sup.on_message("probe/result", rig.result(asked, rig.s.time_s[row]), 0.0);
    }
  }
  INFO("requests " << sup.counts().requests << ", timeouts " << sup.counts().timeouts);
  CHECK(sup.counts().timeouts == 1);  // before: one per sample after the first (357 of 360 requests)
  CHECK(sup.counts().requests == asked);
  CHECK(sup.held() <= 2);             // not 30 min behind
  CHECK(static_cast<std::int64_t>(sup.controller().state().probes.size()) >= asked - 3);
}

TEST_CASE("supervisor: a gateway that answers no probe holds samples for one timeout at a time, not for ever") {
  Rig rig("probe-never", 8.0);
  supervisor::Supervisor sup(rig.config, rig.bus, "test");
  std::size_t most_held = 0;
  double most_behind_s = 0.0;
  for (std::size_t row = 0; row < rig.s.samples(); ++row) {
    sup.on_message("sample", rig.sample(row), 0.0);
    most_held = std::max(most_held, sup.held());
    if (sup.controller().state().started)
      most_behind_s = std::max(most_behind_s, rig.s.time_s[row] - sup.controller().state().now_s);
  }
  INFO("requests " << sup.counts().requests << ", timeouts " << sup.counts().timeouts << ", most held " << most_held
                   << ", most behind " << most_behind_s << " s");
  // Before: after the first timeout each sample of the backlog asked again from the latest sample on,
  // so one sample was released per timeout and the rest held (290 of 300 samples held, 17,400 s behind).
  const double period_s = rig.s.time_s[1] - rig.s.time_s[0];
  CHECK(most_behind_s <= 1800.0 + period_s);  // probe_timeout_s of the rig
  CHECK(most_held <= static_cast<std::size_t>(1800.0 / period_s) + 1);
  CHECK(sup.held() <= static_cast<std::size_t>(1800.0 / period_s) + 1);
  CHECK(sup.counts().timeouts >= 8 * 3600 / (1800 + 2 * 60) - 1);  // one request per timeout and sample after it
  CHECK(sup.counts().requests == sup.counts().timeouts + 1);
}

TEST_CASE("supervisor: a payload with bytes that are not UTF-8 is rejected by name, and the supervisor goes on") {
  Rig rig("latin1", 1.0);
  supervisor::Supervisor sup(rig.config, rig.bus, "test");
  sup.on_message("sample", rig.sample(0), 0.0);
  // A Windows gateway's Latin-1 input name (T_\xE9), and a payload that starts with 0xFF. Before, the
  // event quoting them could not be written as JSON and the supervisor exited.
  Json j = Json::parse(rig.sample(1));
  std::string text = j.dump();
  text.insert(text.find("\"inputs\":{") + 10, "\"T_\xE9\":1,");
  REQUIRE_NOTHROW(sup.on_message("sample", text, 0.0));
  CHECK_THAT(rig.bus.last_event("MessageRejected").value("reason", ""), Catch::Contains("T_\\xE9"));
  REQUIRE_NOTHROW(sup.on_message("sample", "\xFF{}", 0.0));
  CHECK_THAT(rig.bus.last_event("MessageRejected").value("reason", ""), Catch::Contains("\\xFF"));
  CHECK(sup.counts().rejected == 2);
  sup.on_message("sample", rig.sample(1), 0.0);
  CHECK(sup.counts().received == 2);
}

TEST_CASE("supervisor: a result whose time is after its probe's timeout is refused, the right one is learned") {
  Rig rig("probe-future", 1.0);
  supervisor::Supervisor sup(rig.config, rig.bus, "test");
  std::size_t row = 0;
  while (rig.bus.last("probe/request").is_null()) sup.on_message("sample", rig.sample(row++), 0.0);
  const std::int64_t id = rig.bus.last("probe/request")["id"].get<std::int64_t>();
  sup.on_message("probe/result", rig.result(id, 1e12), 0.0);
  CHECK_THAT(rig.bus.last_event("MessageRejected").value("reason", ""), Catch::Contains("is after its timeout"));
  // Before, it was taken: every later sample was held until the machine time reached 1e12 s.
  for (int k = 0; k < 5; ++k) sup.on_message("sample", rig.sample(row++), 0.0);
  sup.on_message("probe/result", rig.result(id, rig.s.time_s[row - 1]), 0.0);
  sup.on_message("sample", rig.sample(row++), 0.0);
  CHECK(sup.held() == 0);
  CHECK(sup.controller().state().probes.size() == 1);
}

TEST_CASE("supervisor: samples far denser than their clock do not pile up without bound while a probe is out") {
  Rig rig("probe-dense", 1.0);
  supervisor::Supervisor sup(rig.config, rig.bus, "test");
  std::size_t row = 0;
  while (rig.bus.last("probe/request").is_null()) sup.on_message("sample", rig.sample(row++), 0.0);
  // 1 ms apart: 25,000 samples are 25 s of machine time, far within probe_timeout_s.
  const double t0 = rig.s.time_s[row];
  Json j = Json::parse(rig.sample(row));
  std::size_t most = 0;
  for (int k = 0; k < 25000; ++k) {
    j["time_s"] = t0 + 0.001 * k;
    sup.on_message("sample", j.dump(), 0.0);
    most = std::max(most, sup.held());
  }
  CHECK(most <= 20000);
  CHECK(sup.counts().timeouts >= 1);
  CHECK_THAT(rig.bus.last_event("ProbeTimeout").value("reason", ""), Catch::Contains("samples were held"));
}

TEST_CASE("supervisor: keep_days deletes old input samples and predictions at snapshots, never what the learning holds, and a restart resumes after it") {
  // A 2 h learning window: the controller holds 1.25 x 2 h + 100 h of warm-up samples at most; 3 h of
  // history kept, snapshots every 0.5 h; the whole of case A (192 h, 11,521 samples).
  Rig rig("retention", 200.0, "keep_days = 0.125\n", "window = 2\n");
  fs::path db = rig.dir / "h.sqlite";
  {
    std::string text;
    std::ifstream in(rig.dir / "s.toml");
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    text.replace(text.find("snapshot_every_h = 2"), 20, "snapshot_every_h = 0.5");
    write(rig.dir / "s.toml", text);
    rig.config = supervisor::read_supervisor_config(rig.dir / "s.toml");
  }
  const auto play = [&](supervisor::Supervisor& sup, std::size_t from, std::size_t to) {
    std::int64_t asked = 0;
    for (std::size_t row = from; row < to; ++row) {
      sup.on_message("sample", rig.sample(row), 0.0);
      const Json request = rig.bus.last("probe/request");
      if (!request.is_null() && request["id"].get<std::int64_t>() > asked) {
        asked = request["id"].get<std::int64_t>();
        sup.on_message("probe/result", rig.result(asked, rig.s.time_s[row]), 0.0);
      }
    }
  };
  const std::size_t rows = rig.s.samples();
  {
    supervisor::Supervisor sup(rig.config, rig.bus, "test");
    play(sup, 0, rows / 2);
    sup.stop();
  }
  std::int64_t pruned_by = 0;
  {
    supervisor::Supervisor sup(rig.config, rig.bus, "test");  // resumes: reads the samples it holds back
    play(sup, rows / 2, rows * 3 / 4);
    sup.stop();
    pruned_by = storage::HistoryReader(db).input_samples(1).front().sample_index;
  }
  // A restart after samples were deleted (before: "run 1 stores 7504 samples before its snapshot, which
  // counts 11475", exit 1 for ever, from day keep_days on).
  REQUIRE(pruned_by > 0);
  std::int64_t first_kept = 0;
  double held_from_s = 0.0;
  {
    supervisor::Supervisor sup(rig.config, rig.bus, "test");
    CHECK(sup.controller().state().samples == static_cast<std::int64_t>(rows * 3 / 4));
    play(sup, rows * 3 / 4, rows);
    CHECK(sup.controller().state().samples == static_cast<std::int64_t>(rows));
    first_kept = sup.controller().state().history_first_index;
    held_from_s = sup.controller().state().history.time_s.front();
    sup.stop();
  }
  const storage::HistoryReader r(db);
  const auto samples = r.input_samples(1);
  REQUIRE_FALSE(samples.empty());
  const double end_s = rig.s.time_s[rows - 1];
  // Old ones are gone (the first day at least), the ones the controller holds stay (it holds more than
  // the 3 h kept: its warm-up), up to the last.
  INFO(samples.size() << " samples kept, from t = " << samples.front().time_s << " s; the controller holds from "
                      << held_from_s << " s");
  CHECK(samples.size() < rows * 7 / 10);
  CHECK(samples.front().time_s > rig.s.time_s[0] + 86400.0);
  CHECK(samples.front().time_s <= held_from_s);
  CHECK(samples.front().sample_index <= first_kept);
  CHECK(samples.back().time_s == end_s);
  const auto predictions = r.predictions(1);
  CHECK(predictions.size() < rows * 7 / 10);
  CHECK(predictions.front().time_s <= held_from_s);
  // What is not samples stays: every probe of the run.
  CHECK(r.probe_measurements(1).size() >= 20);
}

TEST_CASE("supervisor: a sample the controller would refuse (an input beyond its plausible limit) changes nothing") {
  Rig rig("implausible", 1.0);
  supervisor::Supervisor sup(rig.config, rig.bus, "test");
  for (std::size_t row = 0; row < 5; ++row) sup.on_message("sample", rig.sample(row), 0.0);
  REQUIRE(sup.counts().received == 5);
  Json hot = Json::parse(rig.sample(5));
  hot["inputs"][rig.s.input_names[0]] = 500.0;  // 500 °C: beyond the plausible ±200 °C of a T_ input
  sup.on_message("sample", hot.dump(), 0.0);
  CHECK_THAT(rig.bus.last_event("MessageRejected").value("reason", ""), Catch::Contains("beyond the plausible"));
  CHECK(sup.counts().received == 5);  // before: counted as received and as rejected
  CHECK(sup.counts().rejected == 1);
  // The genuine sample of that time is not a "duplicate" (before, the refused one had taken its time).
  sup.on_message("sample", rig.sample(5), 0.0);
  CHECK(sup.counts().received == 6);
  CHECK(sup.counts().rejected == 1);
}

TEST_CASE("supervisor: samples far denser than a minute move the NC offsets no faster than max_step per step_period_s") {
  // max_step of X 0.2 µm per step_period_s = 60 s (the default period). The guard off: the CP model's
  // offsets as they are (after 2 h of CP X is beyond one max_step, so the NC steps).
  Rig rig("rate", 6.0, "", "guard = false\n");
  write(rig.dir / "machine.toml", "[limits.max_step]\nx_mm = 0.0002\n");
  {
    std::ifstream in(rig.dir / "s.toml");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    // Snapshots every 3.6 s of machine time: the restart below resumes from one taken while stepping.
    std::string with_nc = text + "[nc]\nmachine = \"machine.toml\"\n";
    with_nc.replace(with_nc.find("snapshot_every_h = 2"), 20, "snapshot_every_h = 0.001");
    write(rig.dir / "s.toml", with_nc);
    rig.config = supervisor::read_supervisor_config(rig.dir / "s.toml");
  }
  std::optional<supervisor::Supervisor> sup;
  sup.emplace(rig.config, rig.bus, "test");
  const auto x_of = [&] { return rig.bus.last("offsets")["axis"]["x_mm"].get<double>(); };
  std::size_t row = 0;
  std::int64_t asked = 0;
  const auto feed = [&](const std::string& sample) {
    sup->on_message("sample", sample, 0.0);
    const Json request = rig.bus.last("probe/request");
    if (!request.is_null() && request["id"].get<std::int64_t>() > asked) {
      asked = request["id"].get<std::int64_t>();
      sup->on_message("probe/result", rig.result(asked, Json::parse(sample)["time_s"].get<double>()), 0.0);
    }
  };
  // Until the first step of the CP model's offsets.
  while (row < rig.s.samples() && (rig.bus.last("offsets").is_null() || x_of() == 0.0)) feed(rig.sample(row++));
  REQUIRE(row < rig.s.samples() - 1);
  const double x0 = x_of();
  const double t0 = rig.s.time_s[row - 1];
  INFO("first step x " << x0 << " mm at t = " << t0 << " s");
  REQUIRE(std::abs(x0) == Approx(0.0002).margin(1e-12));  // a whole first step: the budget of X is spent
  {
    // The compensation published, which a probe is learned with, is what the offsets in force cancel:
    // before, without a sink, the whole prediction while X held one max_step of it.
    const Json offsets = rig.bus.last("offsets");
    CHECK(std::abs(offsets["compensation"]["E_X0C"].get<double>() - offsets["prediction"]["E_X0C"].get<double>()) > 0.1);
  }
  // The next minute as 600 samples 0.1 s apart, then the recording's own samples a minute apart.
  Json dense = Json::parse(rig.sample(row - 1));
  double x_prev = x0, t_prev = t0, moved_in_minute = 0.0;
  for (int k = 1; k < 600; ++k) {
    // Restarted half way (the budget comes back from its snapshot and the inbox): the limit holds
    // across the restart, no whole step right after it.
    if (k == 300) {
      sup->stop();
      sup.emplace(rig.config, rig.bus, "test");
    }
    dense["time_s"] = t0 + 0.1 * k;
    feed(dense.dump());
    const double x = x_of();
    const double t = t0 + 0.1 * k;
    // Over any span T an axis moves by at most max_step × (1 + T / 60 s); here from the budget spent
    // by the first step: max_step × T / 60 s since it, up to the NC's resolution (steps are whole
    // ticks of 0.0001). Before, every sample stepped by max_step; a budget lost in the restart would
    // allow a whole step at once.
    CHECK(std::abs(x - x0) <= 0.0002 * (t - t0) / 60.0 + 0.5e-4);
    CHECK(std::abs(x - x_prev) <= 0.0002 * (t - t_prev) / 60.0 + 1e-4 + 1e-12);
    moved_in_minute = std::max(moved_in_minute, std::abs(x - x0));
    if (x != x_prev) {
      x_prev = x;
      t_prev = t;
    }
  }
  CHECK(moved_in_minute <= 0.0002 + 1e-12);
  // It does move (the budget refills), and a minute apart the steps are whole again.
  CHECK(moved_in_minute > 0.0);
  const double x_dense_end = x_of();
  for (int k = 0; k < 3 && row < rig.s.samples(); ++k) feed(rig.sample(row++));
  INFO("x " << x0 << " -> " << x_dense_end << " (dense minute) -> " << x_of() << " (three samples a minute apart)");
  CHECK(std::abs(x_of() - x_dense_end) >= 2 * 0.0002 - 1e-12);
  CHECK(std::abs(x_of() - x_dense_end) <= 3 * 0.0002 + 1e-12);
}
