// Every record type written and read back exactly; batching; resume; model JSON; CSV export.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "storage/history_reader.hpp"
#include "storage/history_tools.hpp"
#include "storage/model_json.hpp"
#include "storage/schema.hpp"
#include "storage/storage_error.hpp"
#include "storage_test_support.hpp"

using namespace alc::storage;
using alc::storage::test::RawDb;
using alc::storage::test::ScratchDir;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Bitwise equality so NaN == NaN and -0.0 != 0.0: storage must keep every double exactly.
bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](double x, double y) {
           return std::bit_cast<std::uint64_t>(x) == std::bit_cast<std::uint64_t>(y);
         });
}

}  // namespace

TEST_CASE("every record type round-trips bit for bit", "[storage]") {
  ScratchDir dir;
  const auto file = dir / "history.sqlite";
  const RunRecord run_in = test::small_run();

  InputSampleRecord sample{0, 0, 0.0, {0.1, -0.0, 1e-300}};
  ProbeMeasurementRecord probe{0, 300.0, "CP", {1.25, kNaN}, {-0.5, 3.0000000000000004}, 0.75};
  PredictionRecord prediction{0, 360.0, {2.0 / 3.0, -1e-12}, {0.001, 123456.789}};
  ModelParameterSetRecord model;
  model.time_s = 23400.0;
  model.reason = "end of CP";
  model.window_start_s = -kInf;
  model.window_end_s = 23400.0;
  model.order = 2;
  model.inputs_chosen = {"T_ENV", "n_C"};
  model.usable = true;
  model.adopted = true;
  model.fit_summary_json = R"({"outputs":[{"name":"E_X0C","residual_rms":0.4}]})";
  model.model_json = R"({"parameters":[1,2,3]})";
  PhaseChangeRecord phase{0, 23400.0, "CP", "Post-CP", "CP of 6.5 h complete"};
  ProbeIntervalChangeRecord interval{0, 23400.0, kInf, "Post-CP interval Inf"};
  NcCommandRecord nc{0, 23460.0, "offsets", "G10 L2 P1 X0.0012\n", "file:/tmp/out.nc", false, "sink full, \"retry\""};
  // Accepted by the gate: the sink took it, the sink failed, or not yet handed over.
  NcCommandRecord taken{0, 23460.0, "offsets", "G10 L2 P1 X0.0013\n", "file:/tmp/out", true, "", true,
                        "written to /tmp/out/program.ngc"};
  NcCommandRecord failed{0, 23460.0, "probe_interval", "#3001 = 30\n", "tcp:localhost:5007", true, "", false,
                         "connection refused, \"port 5007\"\n"};
  NcCommandRecord pending{0, 23460.0, "offsets", "G10 L2 P1 X0.0014\n", "file:/tmp/out", true, "split in 2 steps"};
  ControllerSnapshot snapshot{0, 23460.0, 391, "alc.controller/1", false, std::string("\0\x01\xff binary", 10)};

  RunId id = 0;
  {
    HistoryWriter writer(file);
    id = writer.begin_run(run_in);
    sample.run_id = probe.run_id = prediction.run_id = model.run_id = phase.run_id = interval.run_id = nc.run_id =
        taken.run_id = failed.run_id = pending.run_id = snapshot.run_id = id;
    writer.add(sample);
    writer.add(probe);
    writer.add(prediction);
    writer.add(model);
    writer.add(phase);
    writer.add(interval);
    writer.add(nc);
    writer.add(taken);
    writer.add(failed);
    writer.add(pending);
    writer.save_snapshot(snapshot);
    writer.end_run(id, RunStatus::Finished);
  }

  const HistoryReader reader(file);
  CHECK(reader.schema_version() == kSchemaVersion);
  const auto runs = reader.runs();
  REQUIRE(runs.size() == 1);
  const RunRecord& run = runs.front();
  CHECK(run.run_id == id);
  CHECK(run.source == run_in.source);
  CHECK(run.config_json == run_in.config_json);
  CHECK(run.software_version == run_in.software_version);
  CHECK(run.started_unix_s > 1.6e9);
  REQUIRE(run.ended_unix_s);
  CHECK(*run.ended_unix_s >= run.started_unix_s);
  CHECK(run.status == RunStatus::Finished);
  CHECK(run.input_names == run_in.input_names);
  CHECK(run.output_names == run_in.output_names);
  CHECK(run.offset_names == run_in.offset_names);

  const auto samples = reader.input_samples(id);
  REQUIRE(samples.size() == 1);
  CHECK(samples[0].sample_index == 0);
  CHECK(same_bits(samples[0].values, sample.values));

  const auto probes = reader.probe_measurements(id);
  REQUIRE(probes.size() == 1);
  CHECK(probes[0].time_s == probe.time_s);
  CHECK(probes[0].phase == "CP");
  CHECK(same_bits(probes[0].measured, probe.measured));
  CHECK(same_bits(probes[0].compensation, probe.compensation));
  CHECK(probes[0].weight == 0.75);

  const auto predictions = reader.predictions(id);
  REQUIRE(predictions.size() == 1);
  CHECK(same_bits(predictions[0].predicted, prediction.predicted));
  CHECK(same_bits(predictions[0].offsets, prediction.offsets));

  const auto models = reader.model_parameter_sets(id);
  REQUIRE(models.size() == 1);
  CHECK(models[0].reason == model.reason);
  CHECK(models[0].window_start_s == -kInf);
  CHECK(models[0].window_end_s == 23400.0);
  CHECK(models[0].order == 2);
  CHECK(models[0].inputs_chosen == model.inputs_chosen);
  CHECK(models[0].usable);
  CHECK(models[0].adopted);
  CHECK(models[0].fit_summary_json == model.fit_summary_json);
  CHECK(models[0].model_json == model.model_json);

  const auto phases = reader.phase_changes(id);
  REQUIRE(phases.size() == 1);
  CHECK(phases[0].from_phase == "CP");
  CHECK(phases[0].to_phase == "Post-CP");
  CHECK(phases[0].reason == phase.reason);

  const auto intervals = reader.probe_interval_changes(id);
  REQUIRE(intervals.size() == 1);
  CHECK(intervals[0].interval_s == kInf);

  const auto commands = reader.nc_commands(id);
  REQUIRE(commands.size() == 4);
  CHECK(commands[0].text == nc.text);
  CHECK(commands[0].sink == nc.sink);
  CHECK_FALSE(commands[0].accepted);
  CHECK(commands[0].message == nc.message);
  CHECK_FALSE(commands[0].delivered.has_value());
  CHECK(commands[0].delivery_message.empty());
  const NcCommandRecord* in[] = {&nc, &taken, &failed, &pending};
  for (std::size_t i = 0; i < commands.size(); ++i) {
    INFO("NC command " << i);
    CHECK(commands[i].kind == in[i]->kind);
    CHECK(commands[i].text == in[i]->text);
    CHECK(commands[i].sink == in[i]->sink);
    CHECK(commands[i].accepted == in[i]->accepted);
    CHECK(commands[i].message == in[i]->message);
    CHECK(commands[i].delivered == in[i]->delivered);
    CHECK(commands[i].delivery_message == in[i]->delivery_message);
  }
  REQUIRE(commands[1].delivered.has_value());
  CHECK(*commands[1].delivered);
  REQUIRE(commands[2].delivered.has_value());
  CHECK_FALSE(*commands[2].delivered);
  CHECK_FALSE(commands[3].delivered.has_value());

  const auto latest = reader.latest_snapshot(id);
  REQUIRE(latest);
  CHECK(latest->payload == snapshot.payload);  // NUL and 0xff bytes kept
  CHECK(latest->format == snapshot.format);
  CHECK(latest->next_sample_index == 391);
  CHECK(latest->time_s == 23460.0);

  const auto span = reader.time_span(id);
  CHECK_FALSE(span.empty);
  CHECK(span.first_s == 0.0);
  CHECK(span.last_s == 23460.0);
  CHECK(check_history(file).ok());
}

TEST_CASE("records that break the contract are refused with the reason", "[storage]") {
  ScratchDir dir;
  HistoryWriter writer(dir / "h.sqlite");
  const RunId id = writer.begin_run(test::small_run());
  auto sample = test::sample_at(id, 0);
  sample.values.pop_back();
  CHECK_THROWS_WITH(writer.add(sample), Catch::Contains("values has 2 values, the run has 3 channels"));
  CHECK_THROWS_WITH(writer.add(test::sample_at(id + 7, 0)), Catch::Contains("run 8 does not exist"));
  auto bad_time = test::sample_at(id, 0);
  bad_time.time_s = kNaN;
  CHECK_THROWS_WITH(writer.add(bad_time), Catch::Contains("time_s must be finite"));
  // The gate refused it, so no sink can have taken it.
  CHECK_THROWS_WITH(writer.add(NcCommandRecord{id, 0.0, "offsets", "{}", "file:/out", false, "beyond max_offset", true, ""}),
                    Catch::Contains("delivered is set, but the safety gate refused the command"));
  RunRecord bad_config = test::small_run();
  bad_config.config_json = "{not json";
  CHECK_THROWS_WITH(writer.begin_run(bad_config), Catch::Contains("config_json") && Catch::Contains("not valid JSON"));
  writer.add(test::sample_at(id, 0));
  // A duplicate sample index is rejected without losing the rest of the batch.
  CHECK_THROWS_AS(writer.add(test::sample_at(id, 0)), StorageError);
  writer.add(test::sample_at(id, 1));
  writer.commit();
  CHECK(HistoryReader(dir / "h.sqlite").input_samples(id).size() == 2);
}

TEST_CASE("record_delivery sets only the run's accepted, undelivered commands of that sink, committed at once",
          "[storage]") {
  ScratchDir dir;
  const auto file = dir / "delivery.sqlite";
  const std::string sink = "file:/out/A", other_sink = "file:/out/B'); DROP TABLE nc_commands; --";
  HistoryWriter writer(file);
  const RunId run = writer.begin_run(test::small_run());
  const RunId other_run = writer.begin_run(test::small_run());
  const auto command = [](RunId r, double t, const std::string& s, bool accepted) {
    return NcCommandRecord{r, t, "offsets", "G10 L2 P1 X0.001", s, accepted, accepted ? "" : "beyond max_offset"};
  };
  writer.add(command(run, 60.0, sink, true));
  writer.add(command(run, 120.0, sink, false));        // refused: stays NULL
  writer.add(command(run, 180.0, other_sink, true));   // another sink
  writer.add(command(other_run, 180.0, sink, true));   // another run
  NcCommandRecord settled = command(run, 240.0, sink, true);
  settled.delivered = false;
  settled.delivery_message = "an earlier attempt failed";
  writer.add(settled);                                 // already settled: left alone
  writer.add(command(run, 300.0, sink, true));         // still pending in the open batch
  REQUIRE(writer.pending() > 0);

  CHECK(writer.record_delivery(run, sink, true, "written to /out/A/program.ngc") == 2);
  CHECK(writer.pending() == 0);
  {
    // A second connection sees the update while the writer is still open: it is committed.
    const auto rows = HistoryReader(file).nc_commands(run);
    REQUIRE(rows.size() == 5);
    for (std::size_t i : {0u, 4u}) {
      INFO("row " << i);
      CHECK(rows[i].delivered == std::optional<bool>(true));
      CHECK(rows[i].delivery_message == "written to /out/A/program.ngc");
    }
    CHECK_FALSE(rows[1].delivered.has_value());
    CHECK(rows[1].delivery_message.empty());
    CHECK_FALSE(rows[2].delivered.has_value());
    CHECK(rows[3].delivered == std::optional<bool>(false));
    CHECK(rows[3].delivery_message == "an earlier attempt failed");
    const auto others = HistoryReader(file).nc_commands(other_run);
    REQUIRE(others.size() == 1);
    CHECK_FALSE(others[0].delivered.has_value());
  }
  // Nothing left to settle for that sink; the other sink's rows are set by their own call.
  CHECK(writer.record_delivery(run, sink, false, "too late") == 0);
  CHECK(writer.record_delivery(run, other_sink, false, "cannot create /out/B: Permission denied") == 1);
  const auto rows = HistoryReader(file).nc_commands(run);
  CHECK(rows[2].delivered == std::optional<bool>(false));
  CHECK(rows[2].delivery_message == "cannot create /out/B: Permission denied");
  CHECK(rows[0].delivery_message == "written to /out/A/program.ngc");
  CHECK_THROWS_WITH(writer.record_delivery(run + 7, sink, true, ""), Catch::Contains("does not exist"));
  writer.close();
  CHECK(check_history(file).ok());
}

TEST_CASE("records are committed one transaction per batch", "[storage]") {
  ScratchDir dir;
  const auto file = dir / "batched.sqlite";
  WriterOptions options;
  options.batch_size = 100;
  HistoryWriter writer(file, options);
  const RunId id = writer.begin_run(test::small_run());
  const auto commits_after_begin = writer.transactions_committed();
  RawDb peek(file);
  for (std::int64_t k = 0; k < 99; ++k) writer.add(test::sample_at(id, k));
  CHECK(writer.pending() == 99);
  CHECK(peek.scalar("SELECT COUNT(*) FROM input_samples") == 0);  // nothing visible before the batch ends
  writer.add(test::sample_at(id, 99));
  CHECK(writer.pending() == 0);
  CHECK(peek.scalar("SELECT COUNT(*) FROM input_samples") == 100);
  for (std::int64_t k = 100; k < 1050; ++k) writer.add(test::sample_at(id, k));
  CHECK(writer.transactions_committed() - commits_after_begin == 10);  // 1050 records: 10 full batches
  CHECK(peek.scalar("SELECT COUNT(*) FROM input_samples") == 1000);
  writer.commit();  // the caller's commit before acting on what was accepted
  CHECK(writer.transactions_committed() - commits_after_begin == 11);
  CHECK(peek.scalar("SELECT COUNT(*) FROM input_samples") == 1050);
  writer.commit();  // nothing pending: no empty transaction
  CHECK(writer.transactions_committed() - commits_after_begin == 11);
}

TEST_CASE("a history is written with the WAL journal, and the file stays in WAL mode", "[storage]") {
  ScratchDir dir;
  const auto file = dir / "wal.sqlite";
  {
    HistoryWriter writer(file);
    writer.begin_run(test::small_run());  // committed at once
    CHECK(RawDb(file).text("PRAGMA journal_mode") == "wal");
    CHECK(std::filesystem::exists(file.string() + "-wal"));  // commits go to the WAL beside the file
  }
  // Persistent in the file: header bytes 18 and 19 (write and read format versions) are 2 for WAL.
  const std::string bytes = test::read_bytes(file);
  REQUIRE(bytes.size() >= 100);
  CHECK(static_cast<int>(bytes[18]) == 2);
  CHECK(static_cast<int>(bytes[19]) == 2);
  CHECK(RawDb(file).text("PRAGMA journal_mode") == "wal");
  // An older file in another journal mode is switched when a writer opens it.
  REQUIRE(RawDb(file).text("PRAGMA journal_mode = DELETE") == "delete");
  CHECK(test::read_bytes(file)[18] == 1);
  HistoryWriter(file).close();
  CHECK(RawDb(file).text("PRAGMA journal_mode") == "wal");
}

TEST_CASE("resume returns the latest snapshot and drops what was written after it", "[storage]") {
  ScratchDir dir;
  const auto file = dir / "resume.sqlite";
  RunId id = 0;
  {
    HistoryWriter writer(file);
    id = writer.begin_run(test::small_run());
    for (std::int64_t k = 0; k < 30; ++k) {
      writer.add(test::sample_at(id, k));
      writer.add(PredictionRecord{id, 60.0 * static_cast<double>(k), {1.0, 2.0}, {3.0, 4.0}});
      if (k == 9 || k == 19) writer.save_snapshot({id, 60.0 * static_cast<double>(k), k + 1, "test/1", true,
                                                   R"({"k":)" + std::to_string(k) + "}"});
    }
    writer.end_run(id, RunStatus::Stopped);  // e.g. --stop-at: records after the snapshot exist
  }
  {
    HistoryWriter writer(file);
    const ResumePoint point = writer.resume_run(id);
    CHECK(point.snapshot.next_sample_index == 20);
    CHECK(point.snapshot.payload == R"({"k":19})");
    CHECK(point.run.status == RunStatus::Running);
    CHECK(point.run.input_names == test::small_run().input_names);
    const HistoryReader reader(file);
    CHECK(reader.input_samples(id).size() == 20);
    CHECK(reader.predictions(id).size() == 20);
    CHECK(reader.snapshots(id).size() == 2);
    CHECK(reader.latest_unfinished_run()->run_id == id);
    // The resumed run continues and finishes; the history reads as one uninterrupted run.
    for (std::int64_t k = 20; k < 30; ++k) writer.add(test::sample_at(id, k));
    writer.end_run(id, RunStatus::Finished);
  }
  const HistoryReader reader(file);
  CHECK(reader.input_samples(id).size() == 30);
  CHECK_FALSE(reader.latest_unfinished_run());
  CHECK(check_history(file).ok());

  HistoryWriter writer(file);
  const RunId empty = writer.begin_run(test::small_run());
  CHECK_THROWS_WITH(writer.resume_run(empty), Catch::Contains("no controller snapshot"));
}

TEST_CASE("a resume that cannot pair the samples it keeps with their predictions is refused and changes nothing",
          "[storage]") {
  ScratchDir dir;
  const auto file = dir / "unpaired.sqlite";
  RunId id = 0;
  {
    HistoryWriter writer(file);
    id = writer.begin_run(test::small_run());
    for (std::int64_t k = 0; k < 30; ++k) {
      writer.add(test::sample_at(id, k));
      writer.add(PredictionRecord{id, 60.0 * static_cast<double>(k), {1.0, 2.0}, {3.0, 4.0}});
      if (k == 19) writer.save_snapshot({id, 60.0 * static_cast<double>(k), k + 1, "test/1", true, "{}"});
    }
    writer.end_run(id, RunStatus::Stopped);
  }
  REQUIRE(RawDb(file).exec("DELETE FROM input_samples WHERE sample_index = 7") == SQLITE_OK);
  const auto rows = [&] {
    return RawDb(file).text("SELECT (SELECT COUNT(*) FROM input_samples) || ' ' || (SELECT COUNT(*) FROM predictions)"
                            " || ' ' || (SELECT COUNT(*) FROM controller_snapshots) || ' ' || (SELECT status FROM runs)");
  };
  const std::string before = rows();
  CHECK(before == "29 30 1 stopped");
  {
    HistoryWriter writer(file);
    // Before: the rows after the snapshot were deleted and the run marked running, then the replay
    // refused it ("stores 19 samples and 20 predictions before its snapshot"), for ever.
    CHECK_THROWS_WITH(writer.resume_run(id), Catch::Contains("run 1 stores 19 samples and 20 predictions up to its "
                                                             "snapshot 1") &&
                                                 Catch::Contains("nothing was changed"));
  }
  CHECK(rows() == before);
}

TEST_CASE("the indicators a run ends with: stored, replaced, exported, refused when not JSON, removed by a resume",
          "[storage]") {
  ScratchDir dir;
  const auto file = dir / "indicators.sqlite";
  const std::string first = R"({"outputs":{"E_X0C":{"P99":1.5}},"Pd":97.5})";
  const std::string last = R"({"outputs":{"E_X0C":{"P99":1.25}},"Pd":96.0})";
  RunId id = 0, other = 0;
  {
    HistoryWriter writer(file);
    id = writer.begin_run(test::small_run());
    other = writer.begin_run(test::small_run());
    writer.add(test::sample_at(id, 0));
    writer.save_snapshot({id, 0.0, 1, "test/1", true, "{}"});
    CHECK_THROWS_WITH(writer.store_indicators({id, "{\"outputs\": ", 0.0}), Catch::Contains("not valid JSON"));
    CHECK_THROWS_WITH(writer.store_indicators({99, first, 0.0}), Catch::Contains("run 99 does not exist"));
    writer.store_indicators({id, first, 0.0});
    writer.store_indicators({id, last, 1.7e9});  // the run's indicators are replaced, not added
    writer.end_run(id, RunStatus::Stopped);
  }
  {
    const HistoryReader reader(file);
    const auto stored = reader.indicators(id);
    REQUIRE(stored);
    CHECK(stored->report_json == last);
    CHECK(stored->stored_unix_s == 1.7e9);
    CHECK_FALSE(reader.indicators(other));
    const auto counts = reader.table_counts();
    CHECK(std::any_of(counts.begin(), counts.end(),
                      [](const TableCount& c) { return c.table == "run_indicators" && c.rows == 1; }));
    std::ostringstream csv;
    export_table_csv(file, "run_indicators", csv);
    CHECK(csv.str() == "run_id,stored_unix_s,report_json\n1,1.7e+09,\"" +
                           std::string(R"({""outputs"":{""E_X0C"":{""P99"":1.25}},""Pd"":96.0})") + "\"\n");
    CHECK(check_history(file).ok());
  }
  {
    // A resumed run has not ended: what it ended with before is gone until it ends again.
    HistoryWriter writer(file);
    (void)writer.resume_run(id);
    CHECK_FALSE(HistoryReader(file).indicators(id));
    writer.store_indicators({id, first, 0.0});
    writer.end_run(id, RunStatus::Finished);
  }
  CHECK(HistoryReader(file).indicators(id)->report_json == first);
  // `alc db check` names a stored document that is not an indicators object.
  RawDb(file).exec("UPDATE run_indicators SET report_json = '[1, 2]' WHERE run_id = 1");
  const CheckReport report = check_history(file);
  REQUIRE(report.problems.size() == 1);
  CHECK_THAT(report.problems[0], Catch::Contains("run_indicators: run 1"));
}

TEST_CASE("thermal model JSON is exact and the parameter-set record summarises the fit", "[storage]") {
  alc::FitResult fit;
  fit.usable = true;
  fit.message = "ok";
  fit.model.input_names = {"T_ENV", "T_FLUID"};
  fit.model.input_reference = Eigen::VectorXd::Constant(2, 0.1);
  fit.model.base_step_s = 60.0;
  alc::OutputModel out;
  out.name = "E_X0C";
  out.order = 2;
  out.inputs = {0, 1};
  out.parameters = Eigen::VectorXd(3);
  out.parameters << 1.0 / 3.0, -2.5e-17, kNaN;
  out.poles = Eigen::VectorXd::Constant(1, kInf);
  out.output_limit = 45.78812345678901;
  fit.model.outputs.push_back(out);
  alc::OutputFitSummary summary;
  summary.name = "E_X0C";
  summary.usable = true;
  summary.order = 2;
  summary.inputs_chosen = {"T_ENV", "T_FLUID"};
  fit.outputs.push_back(summary);

  const auto back = thermal_model_from_json(thermal_model_to_json(fit.model));
  CHECK(back.input_names == fit.model.input_names);
  REQUIRE(back.outputs.size() == 1);
  CHECK(back.outputs[0].inputs == out.inputs);
  CHECK(back.outputs[0].parameters[0] == 1.0 / 3.0);
  CHECK(back.outputs[0].parameters[1] == -2.5e-17);
  CHECK(std::isnan(back.outputs[0].parameters[2]));
  CHECK(back.outputs[0].poles[0] == kInf);
  // The clamp too (before it was lost, and a resumed run predicted unclamped where the whole one clamped).
  CHECK(back.outputs[0].output_limit == out.output_limit);
  auto without = nlohmann::json::parse(thermal_model_to_json(fit.model));
  without["outputs"][0].erase("output_limit");  // a file written before the clamp was stored: no bound
  CHECK(thermal_model_from_json(without.dump()).outputs[0].output_limit == kInf);

  const auto record = make_model_parameter_set(1, 100.0, "end of CP", 0.0, 100.0, fit, true);
  CHECK(record.order == 2);
  CHECK(record.inputs_chosen == std::vector<std::string>{"T_ENV", "T_FLUID"});
  CHECK(record.usable);
  CHECK_THROWS_AS(thermal_model_from_json("{}"), StorageError);
}

TEST_CASE("export writes CSV with one column per channel and quotes text", "[storage]") {
  ScratchDir dir;
  const auto file = dir / "export.sqlite";
  {
    HistoryWriter writer(file);
    const RunId id = writer.begin_run(test::small_run());
    writer.add(test::sample_at(id, 0));
    writer.add(ProbeMeasurementRecord{id, 60.0, "CP", {1.5, kNaN}, {0.0, 0.25}, 1.0});
    writer.add(PhaseChangeRecord{id, 60.0, "CP", "NG", "residual, \"big\"\nsecond line"});
    writer.add(ProbeIntervalChangeRecord{id, 60.0, kInf, "none"});
    writer.add(NcCommandRecord{id, 60.0, "offsets", "G10", "file:/o", true, "", true, "written to /o/program.ngc"});
    writer.add(NcCommandRecord{id, 60.0, "offsets", "G10", "file:/o", true, "", false, "disk, full"});
    writer.add(NcCommandRecord{id, 60.0, "offsets", "{}", "file:/o", false, "refused"});
  }
  std::ostringstream samples, probes, phases, intervals, commands;
  export_table_csv(file, "input_samples", samples);
  CHECK(samples.str() == "run_id,sample_index,time_s,T_ENV,T_FLUID,n_C\n1,0,0,20,21.5,0\n");
  export_table_csv(file, "probe_measurements", probes);
  CHECK(probes.str() ==
        "run_id,probe_id,time_s,phase,weight,measured_E_X0C,measured_E_A0C,compensation_E_X0C,compensation_E_A0C\n"
        "1,1,60,CP,1,1.5,,0,0.25\n");
  export_table_csv(file, "phase_changes", phases);
  CHECK(phases.str() == "run_id,phase_change_id,time_s,from_phase,to_phase,reason\n1,1,60,CP,NG,\"residual, \"\"big\"\"\nsecond line\"\n");
  export_table_csv(file, "probe_interval_changes", intervals);
  CHECK(intervals.str() == "run_id,interval_change_id,time_s,interval_s,reason\n1,1,60,inf,none\n");
  export_table_csv(file, "nc_commands", commands);
  CHECK(commands.str() ==
        "run_id,nc_command_id,time_s,kind,text,sink,accepted,message,delivered,delivery_message\n"
        "1,1,60,offsets,G10,file:/o,1,,1,written to /o/program.ngc\n"
        "1,2,60,offsets,G10,file:/o,1,,0,\"disk, full\"\n"
        "1,3,60,offsets,{},file:/o,0,refused,,\n");

  std::ostringstream sink;
  CHECK_THROWS_WITH(export_table_csv(file, "runs; DROP TABLE runs", sink), Catch::Contains("no table 'runs; DROP TABLE runs'"));
  CHECK(HistoryReader(file).runs().size() == 1);
  for (const auto& table : exportable_tables()) {
    std::ostringstream out;
    CHECK_NOTHROW(export_table_csv(file, table, out));
  }
}

TEST_CASE("export names an input that bears a fixed column's name by its kind, so no header name repeats", "[storage]") {
  // Before: run_id,sample_index,time_s,sample_index,... and a reader by name took the input for the index.
  ScratchDir dir;
  const auto file = dir / "names.sqlite";
  {
    HistoryWriter writer(file);
    RunRecord run = test::small_run();
    run.input_names = {"sample_index", "run_id", "n_C"};
    const RunId id = writer.begin_run(run);
    writer.add(test::sample_at(id, 0));
  }
  std::ostringstream samples;
  export_table_csv(file, "input_samples", samples);
  CHECK(samples.str() == "run_id,sample_index,time_s,input_sample_index,input_run_id,n_C\n1,0,0,20,21.5,0\n");
}

TEST_CASE("the time span ignores the snapshot taken before the first sample", "[storage]") {
  ScratchDir dir;
  const auto file = dir / "span.sqlite";
  RunId id = 0;
  {
    HistoryWriter writer(file);
    id = writer.begin_run(test::small_run());
    // What replay saves at the start of a run, before the controller has seen a sample.
    writer.save_snapshot({id, kSnapshotBeforeStart_s, 0, "test/1", true, "{}"});
    for (std::int64_t k = 0; k <= 60; ++k) writer.add(test::sample_at(id, k));
    writer.add(PredictionRecord{id, 30.0, {0.5, -0.5}, {1.0, 2.0}});
  }
  const HistoryReader reader(file);
  const TimeSpan span = reader.time_span(id);
  REQUIRE_FALSE(span.empty);
  CHECK(span.first_s == 0.0);
  CHECK(span.last_s == 3600.0);
  // The snapshot itself is kept as written: only the span leaves it out.
  CHECK(reader.latest_snapshot(id)->time_s == kSnapshotBeforeStart_s);
}
