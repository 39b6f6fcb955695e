// Calibration: traces read and replayed faithfully, and Ceres recovering a knee spring 20% softer than the
// model from traces of the worn-knee-spring robot, measured with noise.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "cpgmatch/calibration/calibrated_model.hpp"
#include "cpgmatch/calibration/calibration.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/yaml_reader.hpp"
#include "../support/morti_legs.hpp"
#include "synthetic_traces.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch::calibration {
namespace {

namespace fs = std::filesystem;

using namespace synthetic;  // the robot's traces and their sensor noise

fs::path temp_file(const std::string& name) { return fs::temp_directory_path() / ("cpgmatch_calib_" + name); }

TEST(MeasuredTrace, CsvHoldsWhatTheRolloutRecorded) {
  const fs::path csv = temp_file("roundtrip.csv");
  MeasuredTrace in_memory;
  {
    // The CSV sink closes its file when the last copy of it goes.
    const TraceSink to_file = make_csv_trace(csv.string(), test::morti_legs().names), to_memory = record_trace(in_memory);
    sim::run_sim_rollout(job(model("morti"), 3, 1.5), [&](const TraceSample& s) {
      to_file(s);
      to_memory(s);
    });
  }
  const MeasuredTrace read = read_trace_csv(csv.string());
  ASSERT_EQ(read.ticks.size(), in_memory.ticks.size());
  ASSERT_EQ(read.ticks.size(), 750u);  // 1.5 s at 500 Hz
  for (std::size_t i = 0; i < read.ticks.size(); i += 37) {
    EXPECT_NEAR(read.ticks[i].time_s, in_memory.ticks[i].time_s, 1e-4);
    EXPECT_NEAR(read.ticks[i].pitch_rad, in_memory.ticks[i].pitch_rad, 1e-5);
    for (int leg = 0; leg < kNumLegs; ++leg) {
      EXPECT_NEAR(read.ticks[i].legs[leg].knee_rad, in_memory.ticks[i].legs[leg].knee_rad, 1e-4);
      EXPECT_NEAR(read.ticks[i].legs[leg].hip_target_rad, in_memory.ticks[i].legs[leg].hip_target_rad, 1e-4);
      EXPECT_EQ(read.ticks[i].legs[leg].contact, in_memory.ticks[i].legs[leg].contact);
    }
  }
  fs::remove(csv);
}

void expect_input_error(const std::string& csv_text, const std::string& expected_part) {
  const fs::path csv = temp_file("bad.csv");
  std::ofstream(csv) << csv_text;
  try {
    read_trace_csv(csv.string());
    ADD_FAILURE() << "no error for: " << csv_text;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(expected_part), std::string::npos) << e.what();
  }
  fs::remove(csv);
}

TEST(MeasuredTrace, BadCsvNamesLineAndColumn) {
  std::string header = "time_s,pitch_rad,vx_mps";
  std::string row0 = "0,0,0", row1 = "0.002,0,0";
  for (const char* leg : {"FL", "FR", "HL", "HR"}) {
    header += fmt::format(",{0}_hip_target_rad,{0}_hip_rad,{0}_knee_target_rad,{0}_knee_rad,{0}_foot_force_n,{0}_contact", leg);
    row0 += ",0,0,0,0,10,1";
    row1 += ",0,0,0,0,10,1";
  }
  expect_input_error("time_s,pitch_rad\n0,0\n", ":1: no column 'vx_mps'");
  expect_input_error(header + "\n" + row0 + "\n" + row1.substr(0, row1.size() - 1) + "x\n", ":3: column 'HR_contact': 'x' is not a finite number");
  expect_input_error(header + "\n" + row0 + "\n" + row1.substr(0, row1.size() - 1) + "2\n", ":3: column 'HR_contact': 2 is not 0 or 1");
  expect_input_error(header + "\n" + row1 + "\n", ":2: time_s 0.002");
}

TEST(TraceReplay, OnTheModelThatMadeItGivesTheTraceAgain) {
  const sim::PlanarLegModel m = model("morti");
  const MeasuredTrace trace = recorded(m, 4, 2.0);
  const CalibrationTrace prepared = prepare_trace(trace, matched_trot(), settings(), {}, 4, 2.0);
  const auto replayed = replay(m, prepared.commands, prepared.setup);
  ASSERT_TRUE(replayed);
  ASSERT_EQ(replayed->ticks.size(), trace.ticks.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < trace.ticks.size(); ++i) {
    for (int leg = 0; leg < kNumLegs; ++leg) {
      worst = std::max(worst, std::abs(replayed->ticks[i].legs[leg].knee_rad - trace.ticks[i].legs[leg].knee_rad));
      EXPECT_EQ(replayed->ticks[i].legs[leg].contact, trace.ticks[i].legs[leg].contact) << i;
    }
  }
  EXPECT_LT(worst, 1e-9);
  // The same commands on a softer-kneed body do differ: the replay is not an echo of the trace.
  const auto softer = replay(model("worn-knee-spring"), prepared.commands, prepared.setup);
  ASSERT_TRUE(softer);
  EXPECT_GT(std::abs(softer->ticks[150].legs[0].knee_rad - trace.ticks[150].legs[0].knee_rad), 1e-3);
}

TEST(TraceReplay, RefusesATraceMadeWithOtherParameters) {
  const MeasuredTrace trace = recorded(model("morti"), 4, 1.5);
  CpgParameters other = matched_trot();
  other.hip_amplitude *= 0.8;
  EXPECT_THROW(prepare_trace(trace, other, settings(), {}, 4, 1.5), InputError);
}

TEST(ModelValues, UnknownOrRepeatedNamesAreRefused) {
  EXPECT_EQ(parse_model_value_list("knee_spring.stiffness_nm_per_rad,trunk.mass_kg").size(), 2u);
  EXPECT_THROW(parse_model_value_list("knee_spring.stiffnes"), InputError);
  EXPECT_THROW(parse_model_value_list("trunk.mass_kg,trunk.mass_kg"), InputError);
  EXPECT_THROW(parse_model_value_list("trunk.mass_kg,"), InputError);
}

// The test: traces of a robot whose knee springs are 20% softer than the model's (the shipped
// worn-knee-spring scenario), measured with sensor noise; calibration starts from the model and must find
// the softer spring within 10%.
TEST(Calibration, RecoversAKneeSpring20PercentSofter) {
  const sim::PlanarLegModel robot = model("worn-knee-spring");
  const double truth = robot.knee_spring.stiffness_nm_per_rad;
  ASSERT_NEAR(truth, 0.8 * model("morti").knee_spring.stiffness_nm_per_rad, 1e-9);
  std::vector<CalibrationTrace> traces;
  for (std::uint64_t seed : {11, 12}) {
    MeasuredTrace trace = recorded(robot, seed, 3.0);
    add_sensor_noise(trace, seed);
    // The replay's own contact-sensor noise is another draw than the robot's (seed 0).
    traces.push_back(prepare_trace(std::move(trace), matched_trot(), settings(), {}, 0, 3.0));
  }
  CalibrationOptions options;
  options.values = {&find_model_value("knee_spring.stiffness_nm_per_rad")};
  options.estimate_spread = false;  // the joint fit and the file; the windows' sd: test_calibration_windows.cpp
  Calibration calibration(model("morti"), std::move(traces), options);
  const CalibrationResult result = calibration.solve();
  ASSERT_EQ(result.values.size(), 1u);
  const FittedValue& k = result.values[0];
  std::printf("knee spring: truth %.3f, estimate %.3f +- %.3f N m/rad (error %+.2f%%), cost %.1f -> %.1f, %d iterations, "
              "%ld replays, %.1f s\n",
              truth, k.estimate, k.standard_deviation, 100.0 * (k.estimate / truth - 1.0), result.cost_before,
              result.cost_after, result.iterations, result.simulations, result.wall_time_s);
  EXPECT_NEAR(k.estimate, truth, 0.1 * truth) << result.solver_report;
  EXPECT_FALSE(k.at_bound);
  EXPECT_TRUE(std::isfinite(k.standard_deviation) && k.standard_deviation > 0.0);
  EXPECT_LT(result.cost_after, 0.5 * result.cost_before);
  EXPECT_LT(result.rms_after.knee_rad, result.rms_before.knee_rad);
  // The written model loads, with the estimate in place and the other values untouched.
  std::ifstream in(sim::default_model_path());
  const std::string start_text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string text = calibrated_model_text(start_text, "morti.yaml", result, {"a.csv", "b.csv"});
  const sim::PlanarLegModel calibrated = sim::parse_model_file(YamlReader::from_string(text, "calibrated"));
  EXPECT_NEAR(calibrated.knee_spring.stiffness_nm_per_rad, k.estimate, 1e-4 * k.estimate);
  EXPECT_EQ(calibrated.trunk_mass_kg, model("morti").trunk_mass_kg);
  EXPECT_NE(text.find("calibrated: estimate"), std::string::npos);
}

}  // namespace
}  // namespace cpgmatch::calibration
