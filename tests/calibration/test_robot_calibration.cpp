// Calibrating a robot's description (issue 31): a study of a robot whose "hardware" traces come from a changed
// copy of the robot (simulated, with sensor noise), kept in a study store as the robot agent's are, fitted from
// the study's own robot, and written back as a robot folder that loads, holds the fit where the description
// says it, and differs from the original in nothing else.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "cpgmatch/calibration/calibrated_robot.hpp"
#include "cpgmatch/calibration/robot_values.hpp"
#include "cpgmatch/calibration/study_traces.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/sim/planar_leg_model.hpp"
#include "cpgmatch/study/robot_file.hpp"
#include "cpgmatch/study/spec_rollout.hpp"
#include "synthetic_traces.hpp"

namespace cpgmatch::calibration {
namespace {

namespace fs = std::filesystem;

std::string read(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

study::StudySpec robot_spec(const std::string& robot) {
  return study::StudySpec::resolve(fmt::format("name: calib\nrobot: {}\n", robot), "calib.yaml", study::SpecDefaults::shipped());
}

// The shipped robot with one edit in its robot.yaml or URDF: the "hardware" whose traces are fitted.
sim::PlanarLegModel changed_robot(const std::string& robot, const std::string& yaml_from, const std::string& yaml_to,
                                  const std::string& urdf_from = "", const std::string& urdf_to = "") {
  const fs::path dir = shipped_robots_dir() / robot;
  std::string yaml = read(dir / "robot.yaml"), urdf = read(dir / "robot.urdf");
  if (!yaml_from.empty()) yaml = replaced(yaml, yaml_from, yaml_to);
  if (!urdf_from.empty()) urdf = replaced(urdf, urdf_from, urdf_to);
  return sim::planar_leg_model(parse_robot(yaml, "changed robot.yaml", urdf, "changed robot.urdf"));
}

// The sensor noise a robot adds: synthetic_traces.hpp's, as for Morti's tests.
using synthetic::add_sensor_noise;

// A store holding one study of `spec` whose hardware rollouts (one per seed, 3 s, the spec's base gait with the
// hip amplitude varied) ran on `hardware`: trials reported and traces kept as the optimizer keeps them.
class RobotStore {
 public:
  RobotStore(const study::StudySpec& spec, const sim::PlanarLegModel& hardware, const std::vector<std::uint64_t>& seeds)
      : dir_(fs::temp_directory_path() / fmt::format("cpgmatch-robot-calib-{}-{}", ::getpid(), counter_++)) {
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const std::string worker = spec.robot()->name;
    study::StudyStore store(path());
    study_ = store.create_study("calib", "name: calib\n", "calib.yaml", 1.7e9,
                                {spec.canonical_json(), spec.sha256(), study::kOriginSubmitted});
    for (std::size_t k = 0; k < seeds.size(); ++k) {
      std::map<std::string, double> params = to_map(spec.base_parameters());
      params["hip_amplitude"] *= 1.0 + 0.1 * static_cast<double>(k);  // two gaits, as a study's trials differ
      sim::SimRolloutJob job = study::sim_job_for(spec, params, "flat", seeds[k], 1.0, 2.0);
      job.model = hardware;
      domain::RolloutTrace t;
      t.trace.source = fmt::format("trial {}", k);
      const RolloutResult rollout = sim::run_sim_rollout(job, record_trace(t.trace));
      add_sensor_noise(t.trace, seeds[k]);
      study::StoredTrial trial;
      trial.trial_id = static_cast<int>(k);
      trial.x = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(spec.robot()->search_space.size()));
      trial.worker_id = worker;
      store.add_trials(study_, {trial});
      domain::RolloutReport report;
      report.id = {store.store_id(), study_, trial.trial_id, 0};
      report.worker_id = worker;
      report.worker_kind = domain::WorkerKind::kHardware;
      report.outcome = rollout.fell ? domain::Outcome::kFell : domain::Outcome::kCompleted;
      report.summary.cost = rollout.cost;
      EXPECT_TRUE(store.complete_trial(report, 1.7e9));
      t.id = report.id;
      t.worker_id = worker;
      t.control_rate_hz = job.settings.controller.control_rate_hz;
      t.terrain = "flat";
      t.seed = seeds[k];
      t.parameters = params;
      EXPECT_FALSE(store.save_trace(t, 1.7e9));
    }
  }
  ~RobotStore() { fs::remove_all(dir_); }
  std::string path() const { return (dir_ / "s.db").string(); }
  fs::path dir() const { return dir_; }
  int study() const { return study_; }

 private:
  static inline int counter_ = 0;
  fs::path dir_;
  int study_ = 0;
};

// Every number of a PlanarLegModel, by its model-file name, to compare two models field by field.
std::vector<std::pair<std::string, double>> fields(const sim::PlanarLegModel& m) {
  std::vector<std::pair<std::string, double>> f = {
      {"trunk.mass_kg", m.trunk_mass_kg}, {"trunk.length_m", m.trunk_length_m}, {"trunk.hip_spacing_m", m.hip_spacing_m},
      {"trunk.height_m", m.trunk_height_m}, {"trunk.depth_m", m.trunk_depth_m}, {"femur.length_m", m.femur.length_m},
      {"femur.mass_kg", m.femur.mass_kg}, {"shank.length_m", m.shank.length_m}, {"shank.mass_kg", m.shank.mass_kg},
      {"foot.length_m", m.foot.length_m}, {"foot.mass_kg", m.foot.mass_kg}, {"leg.toe_radius_m", m.toe_radius_m},
      {"leg.femur_mount_angle_rad", m.femur_mount_angle_rad}, {"leg.knee_stand_flexion_rad", m.knee_stand_flexion_rad},
      {"leg.knee_min_flexion_rad", m.knee_min_flexion_rad}, {"leg.knee_max_flexion_rad", m.knee_max_flexion_rad},
      {"leg.ankle_range_rad", m.ankle_range_rad}, {"leg.knee_joint_friction_nm", m.knee_joint_friction_nm},
      {"knee_spring.stiffness_nm_per_rad", m.knee_spring.stiffness_nm_per_rad},
      {"knee_spring.damping_nm_s_per_rad", m.knee_spring.damping_nm_s_per_rad},
      {"biarticular_spring.stiffness_nm_per_rad", m.biarticular_spring.stiffness_nm_per_rad},
      {"biarticular_spring.damping_nm_s_per_rad", m.biarticular_spring.damping_nm_s_per_rad},
      {"knee_parallel_spring.stiffness_nm_per_rad", m.knee_parallel_spring.stiffness_nm_per_rad},
      {"knee_parallel_spring.damping_nm_s_per_rad", m.knee_parallel_spring.damping_nm_s_per_rad},
      {"has_ankle", m.has_ankle ? 1.0 : 0.0}, {"knee_drive", static_cast<double>(m.knee_drive)},
      {"knee_motor.bandwidth_per_s", m.knee_motor_bandwidth_per_s}, {"contact.friction", m.contact.friction},
      {"contact.stiffness_n_per_m", m.contact.stiffness_n_per_m}, {"contact.damping_n_s_per_m", m.contact.damping_n_s_per_m},
      {"foot_sensor.sensitivity", m.foot_sensor.sensitivity}, {"foot_sensor.time_constant_s", m.foot_sensor.time_constant_s},
      {"simulation.physics_rate_hz", m.physics_rate_hz}, {"simulation.gravity_m_s2", m.gravity_m_s2}};
  for (const auto& [name, motor] : {std::pair{"hip_motor", &m.hip_motor}, std::pair{"knee_motor", &m.knee_motor}}) {
    const std::string s = name;
    f.insert(f.end(), {{s + ".stall_torque_nm", motor->stall_torque_nm}, {s + ".no_load_speed_rad_s", motor->no_load_speed_rad_s},
                       {s + ".kp_nm_per_rad", motor->kp_nm_per_rad}, {s + ".kd_nm_s_per_rad", motor->kd_nm_s_per_rad},
                       {s + ".coulomb_friction_nm", motor->coulomb_friction_nm},
                       {s + ".viscous_friction_nm_s_per_rad", motor->viscous_friction_nm_s_per_rad},
                       {s + ".reflected_inertia_kg_m2", motor->reflected_inertia_kg_m2}});
  }
  const std::vector<double> hips = m.hip_positions_m();
  for (std::size_t i = 0; i < hips.size(); ++i) f.push_back({fmt::format("hip_x_m[{}]", i), hips[i]});
  return f;
}

// The written model equals the start model in every field but the fitted ones, which hold the estimates.
void expect_only_fitted_changed(const sim::PlanarLegModel& start, const sim::PlanarLegModel& written,
                                const CalibrationResult& result) {
  const auto a = fields(start), b = fields(written);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto fitted = std::find_if(result.values.begin(), result.values.end(),
                                     [&](const FittedValue& v) { return v.name == a[i].first; });
    if (fitted == result.values.end()) {
      EXPECT_EQ(a[i].second, b[i].second) << a[i].first;
    } else {
      EXPECT_EQ(b[i].second, fitted->estimate) << a[i].first;
    }
  }
}

struct Fit {
  StudyTraces traces;
  CalibrationResult result;
  RobotDescription written;
  double cost_at_truth = 0.0;  // what the fit's cost would be at the hardware's values: its floor with this noise
};

// Loads the store's traces, fits `value_names` on the study's robot and writes the calibrated folder DIR/out.
Fit fit_and_write(const RobotStore& store, const std::string& value_names, const std::vector<double>& truth) {
  const study::StudyStore ro(store.path(), study::kReadOnly);
  Fit fit{load_study_traces(ro, store.study(), 3.0), {}, {}};
  EXPECT_TRUE(fit.traces.robot.has_value());
  const std::vector<ModelValue> values = robot_model_values(parse_model_value_list(value_names), *fit.traces.robot, fit.traces.model);
  CalibrationOptions options;
  for (const ModelValue& v : values) options.values.push_back(&v);
  // What these tests check is the fit and the folder; the windows' spread (test_calibration_windows.cpp) would
  // triple their time.
  options.estimate_spread = false;
  Calibration calibration(fit.traces.model, fit.traces.traces, options);
  fit.result = calibration.solve();
  fit.cost_at_truth = calibration.cost_at(truth);
  const CalibratedRobot files = calibrated_robot(*fit.traces.robot, fit.traces.model_source, fit.result, fit.traces.sources);
  fit.written = write_calibrated_robot((store.dir() / "out").string(), files);
  for (const FittedValue& v : fit.result.values) {
    std::printf("%s: %s %.6g -> %.6g +- %.3g %s, cost %.1f -> %.1f (at the truth %.1f), %d iterations, %ld replays, %.1f s\n",
                fit.traces.robot->name.c_str(), v.name.c_str(), v.initial, v.estimate, v.standard_deviation,
                v.unit.c_str(), fit.result.cost_before, fit.result.cost_after, fit.cost_at_truth, fit.result.iterations,
                fit.result.simulations, fit.result.wall_time_s);
  }
  return fit;
}

// The quadruped's spring across the knee 20% softer than its description (3 -> 2.4 N m/rad), as a worn
// spring would be: the fit recovers it, and the folder written holds it in parallel_springs[0].
TEST(RobotCalibration, RecoversTheQuadrupedsKneeSpring20PercentSofter) {
  const study::StudySpec spec = robot_spec("odrive-quadruped");
  const std::string spring = "stiffness_nm_per_rad: {value: 3.0,";
  const sim::PlanarLegModel hardware = changed_robot("odrive-quadruped", spring, "stiffness_nm_per_rad: {value: 2.4,");
  const double truth = hardware.knee_parallel_spring.stiffness_nm_per_rad;
  ASSERT_NEAR(truth, 0.8 * spec.model().knee_parallel_spring.stiffness_nm_per_rad, 1e-12);
  const RobotStore store(spec, hardware, {11, 12});
  const Fit fit = fit_and_write(store, "knee_parallel_spring.stiffness_nm_per_rad", {truth});
  ASSERT_EQ(fit.result.values.size(), 1u);
  const FittedValue& k = fit.result.values[0];
  EXPECT_EQ(fit.traces.traces.size(), 2u);
  EXPECT_NEAR(k.estimate, truth, 0.02 * truth) << fit.result.solver_report;
  EXPECT_FALSE(k.at_bound);
  EXPECT_TRUE(std::isfinite(k.standard_deviation) && k.standard_deviation > 0.0);
  EXPECT_LT(fit.result.cost_after, 0.5 * fit.result.cost_before);

  // The folder: loads with the project's loader, holds the estimate where robot.yaml keeps the spring, with
  // the note, and builds the original model but for the fitted value.
  EXPECT_EQ(fit.written.parallel_springs.at(0).spring.stiffness_nm_per_rad, k.estimate);
  const std::string yaml = read(store.dir() / "out" / "robot.yaml");
  EXPECT_NE(yaml.find("stiffness_nm_per_rad: {value: " + fmt::format("{}", k.estimate) + ", source: \"calibrated: estimate"),
            std::string::npos);
  EXPECT_NE(yaml.find("before: added, not on the real robot"), std::string::npos);  // the old source kept
  EXPECT_NE(yaml.find("# Calibrated by `cpgmatch calibrate`"), std::string::npos);
  EXPECT_EQ(read(store.dir() / "out" / "robot.urdf"), spec.robot()->urdf_text);  // no mass fitted: as it was
  expect_only_fitted_changed(fit.traces.model, sim::planar_leg_model(fit.written), fit.result);

  // Usable as a study's robot: `robot: out/robot.yaml` beside the study file, another spec than the original's.
  const fs::path study_file = store.dir() / "next.yaml";
  const std::string next = "name: calib\nrobot: out/robot.yaml\n";
  std::ofstream(study_file) << next;
  const study::StudySpec again = study::StudySpec::resolve(study::with_robot_files(next, study_file.string()),
                                                           study_file.string(), study::SpecDefaults::shipped());
  EXPECT_NE(again.sha256(), spec.sha256());
  EXPECT_EQ(again.model().knee_parallel_spring.stiffness_nm_per_rad, k.estimate);
}

// Six legs: the hexapod's trunk 20% heavier than its URDF says (6.6 -> 7.92 kg, a battery added). The mass is
// the URDF's, rewritten with its inertia scaled alike; robot.yaml is untouched but for its header.
TEST(RobotCalibration, RecoversTheHexapodsHeavierTrunkInItsUrdf) {
  const study::StudySpec spec = robot_spec("moteus-hexapod");
  const sim::PlanarLegModel hardware =
      changed_robot("moteus-hexapod", "", "", "<mass value=\"6.6\"/><inertia", "<mass value=\"7.92\"/><inertia");
  const double truth = hardware.trunk_mass_kg;
  ASSERT_NEAR(truth, 1.2 * spec.model().trunk_mass_kg, 1e-12);
  ASSERT_EQ(spec.model().leg_count(), 6u);
  const RobotStore store(spec, hardware, {21, 22});
  const Fit fit = fit_and_write(store, "trunk.mass_kg", {truth});
  const FittedValue& m = fit.result.values.at(0);
  EXPECT_EQ(fit.traces.traces.front().measured.ticks.front().legs.size(), 6u);
  EXPECT_NEAR(m.estimate, truth, 0.02 * truth) << fit.result.solver_report;
  EXPECT_FALSE(m.at_bound);
  EXPECT_LT(fit.result.cost_after, 0.5 * fit.result.cost_before);

  const LinkDescription& before = spec.robot()->link(spec.robot()->root_link);
  const LinkDescription& after = fit.written.link(fit.written.root_link);
  EXPECT_EQ(after.mass_kg, m.estimate);
  for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR(after.inertia_kg_m2[i], before.inertia_kg_m2[i] * m.estimate / 6.6, 1e-12);
  const std::string urdf = read(store.dir() / "out" / "robot.urdf");
  EXPECT_NE(urdf.find("The inertia tensor is scaled by the same ratio"), std::string::npos);
  expect_only_fitted_changed(fit.traces.model, sim::planar_leg_model(fit.written), fit.result);
  // Equal models roll out alike: the written folder's rollout is the fitted model's, to the bit.
  sim::SimRolloutJob job = study::sim_job_for(spec, to_map(spec.base_parameters()), "flat", 3, 0.5, 0.5);
  job.model = fit.result.model;
  const double fitted_cost = sim::run_sim_rollout(job).cost;
  job.model = sim::planar_leg_model(fit.written);
  EXPECT_EQ(sim::run_sim_rollout(job).cost, fitted_cost);
}

void expect_refused(const std::string& robot, const std::string& value, const std::string& part) {
  const study::StudySpec spec = robot_spec(robot);
  try {
    robot_model_values({&find_model_value(value)}, *spec.robot(), spec.model());
    ADD_FAILURE() << value << " on " << robot << ": no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(value), std::string::npos) << what;
    EXPECT_NE(what.find("'" + robot + "'"), std::string::npos) << what;
    EXPECT_NE(what.find(part), std::string::npos) << what;
  }
}

TEST(RobotCalibration, AValueTheRobotLacksIsAnInputErrorNamingIt) {
  expect_refused("moteus-hexapod", "knee_spring.stiffness_nm_per_rad", "has no series knee spring");
  expect_refused("moteus-hexapod", "knee_parallel_spring.stiffness_nm_per_rad", "has no spring across the knee");
  expect_refused("odrive-quadruped", "biarticular_spring.stiffness_nm_per_rad", "has no biarticular spring");
  expect_refused("odrive-quadruped", "knee_spring.stiffness_nm_per_rad", "its spring across the knee is knee_parallel_spring");
  // One motor entry for hip and knee: a hip-only value has nowhere of its own to go.
  expect_refused("odrive-quadruped", "hip_motor.coulomb_friction_nm", "one motor entry, motors.mn5212_belt");
  // Morti's hip has its own motor entry, and every Morti value has its place.
  const study::StudySpec morti = robot_spec("morti");
  for (const char* name : {"hip_motor.coulomb_friction_nm", "knee_spring.stiffness_nm_per_rad", "biarticular_spring.stiffness_nm_per_rad",
                           "leg.knee_joint_friction_nm", "foot_sensor.time_constant_s", "trunk.mass_kg"}) {
    EXPECT_NO_THROW(robot_model_values({&find_model_value(name)}, *morti.robot(), morti.model())) << name;
  }
  EXPECT_EQ(robot_value_site(find_model_value("biarticular_spring.stiffness_nm_per_rad"), *morti.robot()).label,
            "parallel_springs[0].stiffness_nm_per_rad");
  EXPECT_EQ(robot_value_site(find_model_value("hip_motor.coulomb_friction_nm"), *morti.robot()).label,
            "motors.hip_motor.coulomb_friction_nm");
}

// Every kind of place a value lives in, rewritten at once in Morti's description (a series spring inside the
// multi-line flow map of drives.knee, a list item's spring, a motor, contact, the foot sensor, the URDF's mass):
// the texts build Morti's model with exactly these values and nothing else changed. No fit: given estimates.
TEST(RobotCalibration, EveryPlaceAValueLivesIsRewritten) {
  const study::StudySpec spec = robot_spec("morti");
  CalibrationResult result;
  const std::vector<std::pair<const char*, double>> estimates = {
      {"knee_spring.stiffness_nm_per_rad", 12.5},   {"knee_spring.damping_nm_s_per_rad", 0.3},
      {"biarticular_spring.stiffness_nm_per_rad", 3.5}, {"trunk.mass_kg", 3.25},
      {"contact.friction", 0.55},                    {"contact.stiffness_n_per_m", 41000.0},
      {"hip_motor.coulomb_friction_nm", 0.31},       {"hip_motor.reflected_inertia_kg_m2", 0.0045},
      {"leg.knee_joint_friction_nm", 0.04},          {"foot_sensor.time_constant_s", 0.011}};
  for (const auto& [name, value] : estimates) {
    const ModelValue& v = find_model_value(name);
    FittedValue f;
    f.name = name;
    f.unit = v.unit;
    f.initial = v.get(spec.model());
    f.estimate = value;
    f.standard_deviation = 0.001;
    f.lower = v.lower;
    f.upper = v.upper;
    result.values.push_back(f);
  }
  const CalibratedRobot files = calibrated_robot(*spec.robot(), "morti", result, {"t"});
  const RobotDescription back = parse_robot(files.robot_yaml, "robot.yaml", files.urdf, "robot.urdf");
  expect_only_fitted_changed(spec.model(), sim::planar_leg_model(back), result);
  EXPECT_EQ(back.drives.at("knee").series_spring.stiffness_nm_per_rad, 12.5);
  EXPECT_EQ(back.motors.at("hip_motor").coulomb_friction_nm, 0.31);
  EXPECT_EQ(back.motors.at("knee_motor").coulomb_friction_nm, spec.robot()->motors.at("knee_motor").coulomb_friction_nm);
  // Each rewritten entry keeps its old source after the note; the untouched ones are as they were.
  EXPECT_NE(files.robot_yaml.find("before: derived from SLIP scaling"), std::string::npos);
  EXPECT_NE(files.robot_yaml.find("damping_n_s_per_m: {value: 450.0, source: \"assumed; critically damped"), std::string::npos);
  EXPECT_NE(files.robot_yaml.find("# trunk.mass_kg is the URDF's: robot.urdf"), std::string::npos);
}

// Bounds for a robot: a factor of 3 around its own value where the value scales with the robot's size (the
// hexapod's 6.6 kg trunk is outside Morti's 1.5-6 kg), Morti's range where it does not (a friction coefficient).
TEST(RobotCalibration, BoundsAreTheRobotsOwn) {
  const study::StudySpec spec = robot_spec("moteus-hexapod");
  const std::vector<ModelValue> v =
      robot_model_values(parse_model_value_list("trunk.mass_kg,contact.friction"), *spec.robot(), spec.model());
  EXPECT_DOUBLE_EQ(v[0].lower, 2.2);
  EXPECT_DOUBLE_EQ(v[0].upper, 19.8);
  EXPECT_EQ(v[1].lower, find_model_value("contact.friction").lower);
  EXPECT_EQ(v[1].upper, find_model_value("contact.friction").upper);
}

}  // namespace
}  // namespace cpgmatch::calibration
