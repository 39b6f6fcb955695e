// A robot free in 3D (`planar: false`): the ODE plant without the rail. Its trunk rolls, turns and drifts
// sideways; its legs are ODE hinges at their hips' sideways places. Checked against the planar build of the
// same robot where physics says they must agree (standing; a gait whose left and right legs move together
// is mirror-symmetric, so it neither rolls nor turns), and against itself where they must not (a trot
// rocks the trunk about its diagonal; a robot on a stance 2 mm wide tips onto its side, and that is a fall).
#include <algorithm>
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/sim/ode_plant.hpp"
#include "cpgmatch/sim/planar_leg_model.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"

namespace cpgmatch {
namespace {

std::string free_overlay(const std::string& robot) {
  return shipped_robots_dir().string() + "/" + robot + "/scenarios/free-standing.yaml";
}

sim::SimRolloutJob job_for(const RobotDescription& robot, const std::string& preset, const std::string& gait,
                           double entrain_s, double eval_s) {
  sim::SimRolloutJob job;
  job.settings = load_rollout_settings(sim::default_rollout_settings_path());
  job.params = load_parameters(sim::default_params_path());
  job.model = sim::planar_leg_model(robot);
  if (!gait.empty()) job.settings.controller.gait = gait;
  apply_robot_legs(job.settings.controller, robot);
  for (const auto& [key, value] : robot.presets.at(preset)) set_parameter(job.params, key, value, preset);
  job.settings.entrain_s = entrain_s;
  job.settings.eval_s = eval_s;
  return job;
}

struct Excursion {
  double max_abs_roll = 0.0, max_abs_yaw = 0.0, max_abs_lateral = 0.0;
};

Excursion excursion_of(const std::vector<PlantState>& states) {
  Excursion e;
  for (const PlantState& s : states) {
    e.max_abs_roll = std::max(e.max_abs_roll, std::abs(s.trunk.roll_rad));
    e.max_abs_yaw = std::max(e.max_abs_yaw, std::abs(s.trunk.yaw_rad));
    e.max_abs_lateral = std::max(e.max_abs_lateral, std::abs(s.trunk.lateral_m));
  }
  return e;
}

class FreeRobot : public ::testing::TestWithParam<const char*> {};

TEST_P(FreeRobot, OverlayIsTheRobotWithoutItsRail) {
  const RobotDescription planar = load_robot(GetParam());
  const RobotDescription free = load_robot(free_overlay(GetParam()));
  EXPECT_EQ(free.name, planar.name) << "the same robot, so its agent drives it";
  EXPECT_TRUE(planar.planar);
  EXPECT_FALSE(free.planar);
  const sim::PlanarLegModel m = sim::planar_leg_model(free);
  EXPECT_FALSE(m.planar);
  ASSERT_EQ(m.hip_lateral_m.size(), free.legs.size());
  for (std::size_t i = 0; i < free.legs.size(); ++i) {
    EXPECT_EQ(m.hip_lateral_m[i], free.joint(free.legs[i].hip_joint).origin.xyz.y) << free.legs[i].name;
  }
  EXPECT_DOUBLE_EQ(m.total_mass_kg(), sim::planar_leg_model(planar).total_mass_kg());
}

// Standing, the feet of either side carry half the weight each, as the overlapping legs of the rail do: the
// same sag. Upright, the weight is centred and nothing turns the trunk about its roll or yaw axes.
TEST_P(FreeRobot, StandsThreeSecondsUprightAtTheRailsHeight) {
  const sim::PlanarLegModel on_rail = sim::planar_leg_model(load_robot(GetParam()));
  const sim::PlanarLegModel free = sim::planar_leg_model(load_robot(free_overlay(GetParam())));
  sim::OdePlant rail_plant(on_rail, sim::TerrainSpec{}, 0), free_plant(free, sim::TerrainSpec{}, 0);
  EXPECT_DOUBLE_EQ(free_plant.state().trunk.height_m, rail_plant.state().trunk.height_m);
  const PerLeg<JointCommand> hold(free.leg_count());
  rail_plant.command(hold);
  free_plant.command(hold);
  std::vector<PlantState> states;
  for (int i = 0; i < 300; ++i) {
    free_plant.advance(0.01);
    states.push_back(free_plant.state());
  }
  rail_plant.advance(3.0);
  const PlantState f = free_plant.state(), r = rail_plant.state();
  EXPECT_GT(f.trunk.height_m, 0.8 * states.front().trunk.height_m);
  EXPECT_NEAR(f.trunk.height_m, r.trunk.height_m, 1e-3) << "the same legs under the same weight";
  EXPECT_NEAR(f.trunk.pitch_rad, r.trunk.pitch_rad, 1e-3);
  for (std::size_t leg = 0; leg < free.leg_count(); ++leg) {
    EXPECT_NEAR(f.legs[leg].hip_angle_rad, r.legs[leg].hip_angle_rad, 1e-3) << leg;
    EXPECT_NEAR(f.legs[leg].knee_flexion_rad, r.legs[leg].knee_flexion_rad, 1e-3) << leg;
  }
  const Excursion e = excursion_of(states);
  EXPECT_LT(e.max_abs_roll, 1e-3);
  EXPECT_LT(e.max_abs_yaw, 1e-3);
  EXPECT_LT(e.max_abs_lateral, 1e-3);
  EXPECT_LT(free_plant.largest_joint_gap_m(), 60e-6) << "the hinges hold";
}

INSTANTIATE_TEST_SUITE_P(Shipped, FreeRobot, ::testing::Values("odrive-quadruped", "moteus-hexapod"),
                         [](const ::testing::TestParamInfo<const char*>& p) {
                           std::string name = p.param;
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name;
                         });

// A bound moves each front pair and each hind pair together: left and right mirror each other, so the free
// robot neither rolls nor turns, and it walks as it does on the rail. Only the contact sensor's noise
// (drawn per leg) and the hinges' extra rows tell the two apart.
TEST(FreeRobotGait, MirrorSymmetricBoundWalksAsOnTheRail) {
  const RobotDescription planar = load_robot("odrive-quadruped");
  const RobotDescription free = load_robot(free_overlay("odrive-quadruped"));
  sim::SimRolloutJob rail_job = job_for(planar, "trot", "bound", 3.0, 3.0);
  sim::SimRolloutJob free_job = job_for(free, "trot", "bound", 3.0, 3.0);
  const RolloutResult on_rail = sim::run_sim_rollout(rail_job);
  const RolloutResult walked = sim::run_sim_rollout(free_job);
  EXPECT_EQ(walked.fell, on_rail.fell);
  EXPECT_EQ(walked.outcome, on_rail.outcome) << walked.outcome_message;
  EXPECT_NEAR(walked.breakdown.distance_m, on_rail.breakdown.distance_m, 0.05 * std::abs(on_rail.breakdown.distance_m) + 0.02);
  EXPECT_NEAR(walked.cost, on_rail.cost, 0.05 * on_rail.cost);
}

// The same robot trotting free: diagonal pairs carry it in turn, so its weight rocks about the diagonal and
// the trunk rolls: the plant is not a rail in disguise. Whether it stays up is the physics' answer, reported
// in docs/your-robot.md, not asserted here.
TEST(FreeRobotGait, TrotRocksTheTrunkAboutItsDiagonal) {
  const RobotDescription free = load_robot(free_overlay("odrive-quadruped"));
  const sim::PlanarLegModel model = sim::planar_leg_model(free);
  sim::OdePlant plant(model, sim::TerrainSpec{}, 0);
  // Diagonal support by hand: the FL + HR pair carries it while FR and HL lift (knee flexed 0.4 rad).
  PerLeg<JointCommand> lift(model.leg_count());
  lift[1].knee_flexion_rad = 0.4;
  lift[2].knee_flexion_rad = 0.4;
  plant.command(PerLeg<JointCommand>(model.leg_count()));
  plant.advance(1.0);
  plant.command(lift);
  double max_roll = 0.0;
  for (int i = 0; i < 30; ++i) {
    plant.advance(0.01);
    max_roll = std::max(max_roll, std::abs(plant.state().trunk.roll_rad));
  }
  EXPECT_GT(max_roll, 0.01) << "two feet on a diagonal cannot hold the trunk level about it";
}

// A stance 2 mm wide cannot hold a trunk up sideways: it tips onto its side, and the rollout calls that a
// fall (roll past the tilt limit) with the robot still high, not a blow-up.
TEST(FreeRobotGait, ANarrowStanceTipsOverAndThatIsAFall) {
  RobotDescription wide = load_robot(free_overlay("odrive-quadruped"));
  std::string urdf = wide.urdf_text;
  for (const char* from : {"xyz=\"0.19 0.1 0\"", "xyz=\"0.19 -0.1 0\"", "xyz=\"-0.19 0.1 0\"", "xyz=\"-0.19 -0.1 0\""}) {
    std::string to = from;
    to.replace(to.find("0.1 0"), 5, "0.001 0");
    const auto at = urdf.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    urdf.replace(at, std::string(from).size(), to);
  }
  const RobotDescription narrow = parse_robot(wide.yaml_text, "narrow.yaml", urdf, "narrow.urdf");
  sim::SimRolloutJob job = job_for(narrow, "trot", "", 3.0, 3.0);
  const RolloutResult r = sim::run_sim_rollout(job);
  EXPECT_TRUE(r.fell) << to_string(r.outcome) << " " << r.outcome_message;
  EXPECT_EQ(r.outcome, RolloutOutcome::kFell);
}

TEST(FreeRobotErrors, HipsOnOneLineAreRefusedNamingTheRule) {
  const RobotDescription robot = load_robot("odrive-quadruped");
  std::string urdf = robot.urdf_text;
  for (const char* side : {" 0.1 0\"", " -0.1 0\""}) {
    for (std::size_t at = urdf.find(side); at != std::string::npos; at = urdf.find(side)) {
      urdf.replace(at, std::string(side).size(), " 0 0\"");
    }
  }
  std::string yaml = robot.yaml_text;
  const auto at = yaml.find("planar: true");
  ASSERT_NE(at, std::string::npos);
  yaml.replace(at, 12, "planar: false");
  const RobotDescription on_a_line = parse_robot(yaml, "line.yaml", urdf, "line.urdf");
  try {
    (void)sim::planar_leg_model(on_a_line);
    FAIL() << "accepted a free robot whose feet stand on one line";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("both sides"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("line.yaml"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cpgmatch
