// A robot as data: Morti read from configs/robots/morti/ (URDF + robot.yaml) against the hand-written model
// configs/model/morti.yaml, and every bad description refused with the element and its file:line.
#include <cctype>
#include <cmath>
#include <random>
#include <regex>

#include <gtest/gtest.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/sim/ode_plant.hpp"
#include "cpgmatch/sim/planar_leg_model.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/text.hpp"
#include "model_equality.hpp"

namespace cpgmatch {
namespace {

std::string robot_dir() { return shipped_robots_dir().string() + "/morti"; }

TEST(ShippedRobots, MortiIsListedAndLoads) {
  const auto names = shipped_robot_names();
  ASSERT_NE(std::find(names.begin(), names.end(), "morti"), names.end());
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    const RobotDescription robot = load_robot(name);
    EXPECT_EQ(robot.name, name);
    EXPECT_GE(robot.legs.size(), 2u);
    EXPECT_FALSE(robot.gaits.empty());
    EXPECT_FALSE(robot.search_space.empty());
  }
}

TEST(MortiFromUrdf, LegsJointsAndGroupsAreTheYamls) {
  const RobotDescription robot = load_robot("morti");
  ASSERT_EQ(robot.legs.size(), 4u);
  EXPECT_EQ(robot.legs[0].name, "FL");
  EXPECT_EQ(robot.legs[3].name, "HR");
  EXPECT_EQ(robot.legs[2].knee_joint, "HL_knee");
  EXPECT_EQ(robot.groups, (std::vector<std::string>{"front", "hind"}));
  EXPECT_EQ(robot.root_link, "trunk");
  EXPECT_EQ(robot.links.size(), 13u);
  EXPECT_EQ(robot.joints.size(), 12u);
  EXPECT_EQ(robot.gaits.front().name, "trot");
  EXPECT_EQ(robot.gaits.front().phase_offsets, (std::vector<double>{0.0, 0.5, 0.5, 0.0}));
}

// Every value of the simulation's model, read from the URDF and robot.yaml, equals the hand-written file's.
TEST(MortiFromUrdf, ModelEqualsTheHandWrittenModel) {
  testing_support::expect_models_equal(sim::planar_leg_model(load_robot("morti")), sim::load_model_file(sim::default_model_path()));
}

// The URDF's inertias are those of the bodies the ODE plant builds (slender 0.02 m bars, the trunk's box)
// about their pitch axis (URDF y) and the other two.
TEST(MortiFromUrdf, InertiasAreThePlantsBodies) {
  const RobotDescription robot = load_robot("morti");
  const sim::PlanarLegModel m = sim::load_model_file(sim::default_model_path());
  auto bar = [](double mass, double length) {
    return std::array<double, 3>{mass / 12 * (length * length + 0.0004), mass / 12 * (length * length + 0.0004), mass / 12 * 0.0008};
  };
  const double tm = m.trunk_mass_kg, L = m.trunk_length_m, H = m.trunk_height_m, D = m.trunk_depth_m;
  const std::map<std::string, std::array<double, 3>> expected_by_kind{
      {"femur", bar(m.femur.mass_kg, m.femur.length_m)}, {"shank", bar(m.shank.mass_kg, m.shank.length_m)},
      {"foot", bar(m.foot.mass_kg, m.foot.length_m)},
      {"trunk", {tm / 12 * (D * D + H * H), tm / 12 * (L * L + H * H), tm / 12 * (L * L + D * D)}}};
  int checked = 0;
  for (const LinkDescription& link : robot.links) {
    const std::string kind = link.name == "trunk" ? "trunk" : link.name.substr(link.name.find('_') + 1);
    const auto& e = expected_by_kind.at(kind);
    EXPECT_NEAR(link.inertia_kg_m2[0], e[0], 1e-12) << link.name << " ixx";
    EXPECT_NEAR(link.inertia_kg_m2[3], e[1], 1e-12) << link.name << " iyy (pitch)";
    EXPECT_NEAR(link.inertia_kg_m2[5], e[2], 1e-12) << link.name << " izz";
    ++checked;
  }
  EXPECT_EQ(checked, 13);
}

TEST(MortiFromUrdf, TotalMassAndStandingHeightAreThePlants) {
  const RobotDescription robot = load_robot("morti");
  const sim::PlanarLegModel m = sim::load_model_file(sim::default_model_path());
  EXPECT_NEAR(robot.total_mass_kg(), m.total_mass_kg(), 1e-12);
  EXPECT_NEAR(robot.total_mass_kg(), 3.88, 1e-12);
  sim::OdePlant plant(m, sim::TerrainSpec{}, 0);
  EXPECT_NEAR(sim::standing_trunk_height_m(robot), plant.state().trunk.height_m, 1e-9);
  EXPECT_GT(sim::standing_trunk_height_m(robot), 0.25);  // notes: 0.25-0.32 m
  EXPECT_LT(sim::standing_trunk_height_m(robot), 0.32);
}

// The shipped presets and 20 random gaits of the robot's search space cost the same, and fall the same,
// on Morti built from its URDF as on the hand-written model (tolerance 1e-9 of the cost: the two models'
// values agree to 1e-12, so any larger difference is a different model).
TEST(MortiFromUrdf, RolloutCostsAndFallsMatchTheHandWrittenModel) {
  const RobotDescription robot = load_robot("morti");
  sim::SimRolloutJob by_hand;
  by_hand.settings = load_rollout_settings(sim::default_rollout_settings_path());
  by_hand.settings.entrain_s = 3.0;  // short rollouts: the models are equal or they are not within seconds
  by_hand.settings.eval_s = 3.0;
  by_hand.model = sim::load_model_file(sim::default_model_path());
  sim::SimRolloutJob from_urdf = by_hand;
  from_urdf.model = sim::planar_leg_model(robot);

  std::vector<CpgParameters> gaits;
  for (const auto& [name, values] : robot.presets) {
    CpgParameters p;
    for (const auto& [key, value] : values) set_parameter(p, key, value);
    gaits.push_back(p);
  }
  std::mt19937_64 rng(7);
  for (int i = 0; i < 20; ++i) {
    CpgParameters p = gaits.front();
    for (const SearchParameter& s : robot.search_space) {
      set_parameter(p, s.name, std::uniform_real_distribution<double>(s.low, s.high)(rng));
    }
    gaits.push_back(p);
  }
  int falls = 0;
  for (std::size_t i = 0; i < gaits.size(); ++i) {
    by_hand.params = from_urdf.params = gaits[i];
    const RolloutResult a = sim::run_sim_rollout(by_hand);
    const RolloutResult b = sim::run_sim_rollout(from_urdf);
    EXPECT_NEAR(a.cost, b.cost, 1e-9 * std::max(1.0, a.cost)) << "gait " << i;
    EXPECT_EQ(a.fell, b.fell) << "gait " << i;
    falls += a.fell;
  }
  EXPECT_EQ(gaits.size(), 23u);
  RecordProperty("falls", falls);
}

// ---- bad input: each mutation of Morti's texts is refused, naming the element and where it is ----

struct Texts {
  std::string yaml, urdf;
};

Texts morti_texts() {
  return {read_text_file(robot_dir() + "/robot.yaml", "robot.yaml"), read_text_file(robot_dir() + "/robot.urdf", "robot.urdf")};
}

std::string replace_once(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "the test's anchor '" << from << "' is gone from Morti's files";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

std::string error_of(const Texts& t) {
  try {
    parse_robot(t.yaml, "robot.yaml", t.urdf, "robot.urdf");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

// The two robots shipped beside Morti (docs/your-robot.md "Shipped robots"): a two-segment-leg quadruped and a
// hexapod, with the leg and joint names of their hardware files (configs/robot/odrive-quadruped.yaml,
// moteus-hexapod.yaml). Each stands 3 s on its own springs and motors, and its hand-chosen preset walks 20 s
// (the rollout settings' 10 s entrainment + 10 s evaluation) without falling, forward at > 0.2 m/s; the
// hexapod also in its ripple and wave gaits with its `slow` preset.
struct ShippedWalker {
  const char* robot;
  const char* preset;
  const char* gait;  // empty: the robot's default
  std::vector<std::string> legs;
};

// Names the case in test listings (ctest shows GetParam()).
void PrintTo(const ShippedWalker& w, std::ostream* os) { *os << w.robot << " preset " << w.preset << " gait " << (*w.gait ? w.gait : "default"); }

sim::SimRolloutJob walker_job(const RobotDescription& robot, const ShippedWalker& w) {
  sim::SimRolloutJob job;
  job.settings = load_rollout_settings(sim::default_rollout_settings_path());
  job.params = load_parameters(sim::default_params_path());
  job.model = sim::planar_leg_model(robot);
  if (*w.gait) job.settings.controller.gait = w.gait;
  apply_robot_legs(job.settings.controller, robot);
  for (const auto& [key, value] : robot.presets.at(w.preset)) set_parameter(job.params, key, value, w.preset);
  return job;
}

class ShippedWalkers : public ::testing::TestWithParam<ShippedWalker> {};

TEST_P(ShippedWalkers, LegsAreTheHardwareFilesTwoSegmentsEach) {
  const ShippedWalker& w = GetParam();
  const RobotDescription robot = load_robot(w.robot);
  ASSERT_EQ(robot.legs.size(), w.legs.size());
  for (std::size_t i = 0; i < w.legs.size(); ++i) {
    EXPECT_EQ(robot.legs[i].name, w.legs[i]);
    EXPECT_EQ(robot.legs[i].hip_joint, w.legs[i] + "_hip");
    EXPECT_EQ(robot.legs[i].knee_joint, w.legs[i] + "_knee");
    EXPECT_TRUE(robot.legs[i].ankle_joint.empty()) << "two-segment legs";
  }
  const sim::PlanarLegModel m = sim::planar_leg_model(robot);
  EXPECT_FALSE(m.has_ankle);
  EXPECT_EQ(m.leg_count(), w.legs.size());
  EXPECT_EQ(m.knee_drive, sim::PlanarLegModel::KneeDrive::kPositionPd);  // unlike Morti's series-elastic knee
}

TEST_P(ShippedWalkers, StandsThreeSeconds) {
  const RobotDescription robot = load_robot(GetParam().robot);
  const sim::PlanarLegModel m = sim::planar_leg_model(robot);
  sim::OdePlant plant(m, sim::TerrainSpec{}, 0);
  const double start = plant.state().trunk.height_m;
  EXPECT_NEAR(start, sim::standing_trunk_height_m(robot), 1e-9);
  plant.command(PerLeg<JointCommand>(m.leg_count()));
  plant.advance(3.0);
  const PlantState s = plant.state();
  // The legs give under the body's weight (the knees are springs), by less than a fifth of the height.
  EXPECT_GT(s.trunk.height_m, 0.8 * start);
  EXPECT_LT(s.trunk.height_m, start);
  EXPECT_LT(std::abs(s.trunk.pitch_rad), 0.05);
}

TEST_P(ShippedWalkers, HandChosenPresetWalksWithoutFalling) {
  const ShippedWalker& w = GetParam();
  const RobotDescription robot = load_robot(w.robot);
  const sim::SimRolloutJob job = walker_job(robot, w);
  for (std::uint64_t seed : {0u, 1u}) {
    SCOPED_TRACE(seed);
    sim::SimRolloutJob j = job;
    j.seed = seed;
    const RolloutResult r = sim::run_sim_rollout(j);
    EXPECT_EQ(r.outcome, RolloutOutcome::kCompleted) << r.outcome_message;
    EXPECT_FALSE(r.fell);
    EXPECT_GT(r.breakdown.mean_speed_mps, 0.2);
    EXPECT_GT(r.breakdown.distance_m, 2.0);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Robots, ShippedWalkers,
    ::testing::Values(ShippedWalker{"odrive-quadruped", "trot", "", {"FL", "FR", "HL", "HR"}},
                      ShippedWalker{"moteus-hexapod", "tripod", "", {"L1", "R1", "L2", "R2", "L3", "R3"}},
                      ShippedWalker{"moteus-hexapod", "slow", "ripple", {"L1", "R1", "L2", "R2", "L3", "R3"}},
                      ShippedWalker{"moteus-hexapod", "slow", "wave", {"L1", "R1", "L2", "R2", "L3", "R3"}}),
    [](const ::testing::TestParamInfo<ShippedWalker>& param_info) {
      const ShippedWalker& w = param_info.param;
      std::string name = std::string(w.robot) + "_" + w.preset + "_" + w.gait;
      for (char& c : name) if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return name;
    });

TEST(RobotDescriptionErrors, EachBadDescriptionNamesTheElementAndItsLine) {
  const Texts good = morti_texts();
  ASSERT_EQ(error_of(good), "(accepted)");
  struct Case {
    const char* what;
    Texts texts;
    const char* expected;  // a regular expression the message must match
  };
  const std::vector<Case> cases{
      {"URDF that is not XML", {good.yaml, replace_once(good.urdf, "</robot>", "")}, R"(robot\.urdf:\d+: not well-formed XML)"},
      {"URDF that is not a tree (two roots)",
       {good.yaml, replace_once(good.urdf, "</robot>", R"(<link name="loose"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link></robot>)")},
       R"(robot\.urdf: not a valid URDF: .*(root|parent))"},
      {"a link without inertia",
       {good.yaml, replace_once(good.urdf, R"(<link name="FL_shank">
    <inertial><origin xyz="0 0 -0.06" rpy="0 0 0"/><mass value="0.08"/><inertia ixx="9.866666666666666e-05" ixy="0" ixz="0" iyy="9.866666666666666e-05" iyz="0" izz="5.333333333333334e-06"/></inertial>)",
                                R"(<link name="FL_shank">)")},
       R"(robot\.urdf:\d+: link 'FL_shank' has no <inertial>)"},
      {"a non-positive mass", {good.yaml, replace_once(good.urdf, R"(<mass value="0.04"/>)", R"(<mass value="-0.04"/>)")},
       R"(robot\.urdf:\d+: link 'FL_foot': mass must be > 0 kg)"},
      {"a joint the YAML names that the URDF lacks", {replace_once(good.yaml, "knee: HL_knee", "knee: HL_knee_joint"), good.urdf},
       R"(robot\.yaml:\d+: field 'legs\[2\]\.knee': joint 'HL_knee_joint' is not in robot\.urdf)"},
      {"a leg without a foot collision shape",
       {good.yaml, replace_once(good.urdf, R"(<collision><origin xyz="0 0 -0.07" rpy="0 0 0"/><geometry><sphere radius="0.012"/></geometry></collision>)", "")},
       R"(robot\.yaml:\d+: field 'legs\[0\]\.foot': link 'FL_foot' \(robot\.urdf:\d+\) has no <collision> sphere)"},
      {"a search-space name no gait uses", {replace_once(good.yaml, "  overswing: {low: 0.0, high: 0.5}", "  overswing: {low: 0.0, high: 0.5}\n  tail_wag: {low: 0.0, high: 1.0}"), good.urdf},
       R"(robot\.yaml:\d+: field 'search_space\.tail_wag': no gait uses it)"},
      {"a gait with the wrong number of offsets", {replace_once(good.yaml, "pace: [0.0, 0.5, 0.0, 0.5]", "pace: [0.0, 0.5, 0.0]"), good.urdf},
       R"(robot\.yaml:\d+: field 'gaits\.pace': must list 4 phase offsets)"},
      {"an unknown drive", {replace_once(good.yaml, "kind: passive", "kind: hydraulic"), good.urdf},
       R"(robot\.yaml:\d+: field 'drives\.ankle\.kind': unknown drive 'hydraulic')"},
      {"an unknown motor", {replace_once(good.yaml, "motor: knee_motor,", "motor: knee_motr,"), good.urdf},
       R"(robot\.yaml:\d+: field 'drives\.knee\.motor': unknown motor 'knee_motr')"},
      {"a knee that does not hang from the femur", {replace_once(good.yaml, "hip: FR_hip, knee: FR_knee", "hip: FR_hip, knee: FL_knee"), good.urdf},
       R"(robot\.yaml:\d+: field 'legs\[1\]\.knee': joint 'FL_knee' hangs from link 'FL_femur', not from 'FR_femur')"},
      {"a leg named twice", {replace_once(good.yaml, "{name: FR,", "{name: FL,"), good.urdf},
       R"(robot\.yaml:\d+: field 'legs\[1\]\.name': leg 'FL' is named twice)"},
      {"an inverted joint limit", {good.yaml, replace_once(good.urdf, R"(<limit lower="-0.8" upper="1.4")", R"(<limit lower="1.4" upper="-0.8")")},
       R"(robot\.urdf:\d+: joint 'FL_knee': limit lower 1\.4 must be below upper -0\.8)"},
      {"bidi override echoed escaped", {replace_once(good.yaml, "knee: HL_knee", "knee: \"HL_\u202eknee\""), good.urdf},
       R"(joint 'HL_\\u202eknee' is not in)"},
  };
  for (const Case& c : cases) {
    const std::string message = error_of(c.texts);
    EXPECT_TRUE(std::regex_search(message, std::regex(c.expected))) << c.what << "\n  got: " << message << "\n  want: " << c.expected;
  }
}

TEST(RobotDescriptionErrors, SpecialFilesAndUnknownNamesAreRefusedBeforeReading) {
  EXPECT_THROW(load_robot("/dev/zero"), InputError);
  try {
    load_robot("no-such-robot");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("shipped: "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("morti"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cpgmatch

namespace cpgmatch {
namespace {

// A six-legged robot made from Morti's files for this test: two more legs (ML, MR) at the trunk's centre,
// alike to the others, and the tripod gait. The plant builds it, the controller drives six legs, and the
// tripod's phase offsets hold in simulation (the legs' phases stay locked through 10 s of walking, contacts
// and feedback included).
Texts six_legged_morti() {
  Texts t = morti_texts();
  const auto fl_begin = t.urdf.find(R"(<link name="FL_femur">)");
  const auto fl_end = t.urdf.find(R"(<link name="FR_femur">)");
  std::string fl = t.urdf.substr(fl_begin, fl_end - fl_begin);
  std::string middle;
  for (const auto& [name, y] : {std::pair{"ML", "0.075"}, std::pair{"MR", "-0.075"}}) {
    std::string leg = std::regex_replace(fl, std::regex("FL_"), std::string(name) + "_");
    leg = std::regex_replace(leg, std::regex(R"(xyz="0\.2 0\.075 0")"), std::string("xyz=\"0.0 ") + y + " 0\"");
    middle += leg;
  }
  t.urdf.insert(fl_end, middle);
  t.yaml = replace_once(t.yaml, "  - {name: HL,", "  - {name: ML, group: middle, hip: ML_hip, knee: ML_knee, ankle: ML_ankle, foot: ML_foot}\n"
                                              "  - {name: MR, group: middle, hip: MR_hip, knee: MR_knee, ankle: MR_ankle, foot: MR_foot}\n"
                                              "  - {name: HL,");
  // FL FR ML MR HL HR: tripods FL MR HL and FR ML HR.
  t.yaml = std::regex_replace(t.yaml, std::regex(R"(gaits:\n(  [a-z]+: \[[^\]]*\].*\n)+)"),
                              "gaits:\n  tripod: [0.0, 0.5, 0.5, 0.0, 0.0, 0.5]\n");
  t.yaml = replace_once(t.yaml, "default_gait: trot", "default_gait: tripod");
  return t;
}

TEST(SixLegs, TheTripodGaitLocksInSimulation) {
  const Texts texts = six_legged_morti();
  const RobotDescription robot = parse_robot(texts.yaml, "six.yaml", texts.urdf, "six.urdf");
  ASSERT_EQ(robot.legs.size(), 6u);
  EXPECT_EQ(robot.groups, (std::vector<std::string>{"front", "middle", "hind"}));
  const sim::PlanarLegModel model = sim::planar_leg_model(robot);
  EXPECT_EQ(model.leg_count(), 6u);
  EXPECT_NEAR(model.total_mass_kg(), 3.0 + 6 * 0.22, 1e-12);

  sim::SimRolloutJob job;
  job.settings = load_rollout_settings(sim::default_rollout_settings_path());
  job.settings.entrain_s = 5.0;
  job.settings.eval_s = 5.0;
  apply_robot_legs(job.settings.controller, robot);
  ASSERT_EQ(job.settings.controller.gait, "tripod");
  job.model = model;
  for (const auto& [key, value] : robot.presets.at("matched-trot")) set_parameter(job.params, key, value);
  double worst_lock = 0.0;
  std::size_t legs_seen = 0;
  const RolloutResult r = sim::run_sim_rollout(job, [&](const TraceSample& s) {
    legs_seen = s.state->legs.size();
    if (s.time_s < 2.0) return;
    // Within each tripod the phases agree; between the two they are half a cycle apart.
    const auto& ph = s.output->phases;
    auto diff = [](double a, double b) { return std::abs(std::remainder(a - b, 1.0)); };
    for (int a : {0, 3, 4}) worst_lock = std::max(worst_lock, diff(ph[a], ph[0]));
    for (int b : {1, 2, 5}) worst_lock = std::max(worst_lock, std::abs(diff(ph[b], ph[0]) - 0.5));
  });
  EXPECT_EQ(legs_seen, 6u);
  EXPECT_FALSE(r.fell) << r.outcome_message;
  EXPECT_GT(r.breakdown.distance_m, 0.5);  // it walks
  // The feedback holds a leg back while its ground is missing; the coupling pulls it back into the tripod.
  EXPECT_LT(worst_lock, 0.15) << "largest deviation from the tripod's phase offsets, cycles";
  EXPECT_EQ(r.energy.hip.size(), 6u);
}

}  // namespace
}  // namespace cpgmatch
