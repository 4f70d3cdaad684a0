// The history of a replay: the offsets stored with each prediction are the ones that cancel it.
#include <catch2/catch.hpp>
#include <unistd.h>

#include <filesystem>
#include <limits>

#include "scenarios/load_cases.hpp"
#include "scenarios/replay_history.hpp"
#include "storage/history_reader.hpp"

using namespace alc;
using namespace alc::scenarios;

TEST_CASE("replay history: every prediction is stored with the axis offsets that cancel it") {
  const auto dir = std::filesystem::temp_directory_path() / ("alc_replay_history_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto file = dir / "offsets.sqlite";
  std::filesystem::remove(file);
  const auto simulated = simulate_case("A");
  const Scenario& sc = simulated.scenario;
  const auto chain = kinematics::MachineChain::bc_trunnion();  // not the default: the names follow the chain
  storage::RunId run = 0;
  {
    storage::HistoryWriter writer(file);
    storage::RunRecord r;
    r.source = "A";
    r.input_names = sc.input_names;
    r.output_names = sc.output_names;
    r.offset_names = HistoryRecorder::offset_names(chain);
    run = writer.begin_run(r);
    ReplaySession session(sc, AlcParameters{});
    HistoryRecorder recorder(writer, run, session.controller());
    recorder.record_offsets(chain, sc.output_names);
    session.run(12 * 3600.0, &recorder);
    writer.end_run(run, storage::RunStatus::Stopped);
  }
  const storage::HistoryReader reader(file);
  CHECK(reader.runs().at(0).offset_names == std::vector<std::string>{"X_um", "Y_um", "Z_um", "B_urad", "C_urad"});
  const auto predictions = reader.predictions(run);
  REQUIRE(predictions.size() > 700);  // 12 h at 1 min
  int nonzero = 0;
  for (std::size_t k = 0; k < predictions.size(); k += 37) {
    const auto& p = predictions[k];
    REQUIRE(p.offsets.size() == 5);
    const Eigen::VectorXd predicted = Eigen::Map<const Eigen::VectorXd>(p.predicted.data(), static_cast<Eigen::Index>(p.predicted.size()));
    const auto c = kinematics::compensate(chain, {}, kinematics::location_errors_of(sc.output_names, predicted));
    REQUIRE(c.converged);
    CHECK(p.offsets[0] == c.offsets.x_um);
    CHECK(p.offsets[1] == c.offsets.y_um);
    CHECK(p.offsets[2] == c.offsets.z_um);
    CHECK(p.offsets[3] == c.offsets.tilt_urad);
    CHECK(p.offsets[4] == c.offsets.table_urad);
    nonzero += std::abs(p.offsets[0]) > 1.0 ? 1 : 0;
  }
  CHECK(nonzero > 5);  // after CP (6.5 h) the model compensates micrometres
  std::filesystem::remove_all(dir);
}

TEST_CASE("kinematics: output names map to the seven location errors, others are ignored") {
  const std::vector<std::string> names{"E_C0C", "T_X", "E_X0C", "E_Z1", "E_R0T", "E_B0C"};
  Eigen::VectorXd v(6);
  v << 30.0, 99.0, 1.5, 77.0, std::numeric_limits<double>::quiet_NaN(), -4.0;
  const auto e = kinematics::location_errors_of(names, v);
  CHECK(e.c0c_um_per_m == 30.0);
  CHECK(e.x0c_um == 1.5);
  CHECK(e.r0t_um == 0.0);  // NaN: not measured, stays zero
  CHECK(e.b0c_um_per_m == -4.0);
  CHECK(e.y0c_um == 0.0);
  CHECK(e.z0t_um == 0.0);
  CHECK(e.a0c_um_per_m == 0.0);
  CHECK(kinematics::location_error_field("E_Z0T") == 2);
  CHECK(kinematics::location_error_field("E_Z1") == -1);
}
