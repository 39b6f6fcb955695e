// The study owns its robot (issue 31): `robot: NAME|PATH` puts the robot's whole description (both texts)
// into the spec under its hash; a worker builds the robot's model, legs and gaits from the spec alone; a
// robot agent whose body is another robot's refuses the study with the reason.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot/robot_config.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/sim/planar_leg_model.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/study/robot_file.hpp"
#include "cpgmatch/study/spec_rollout.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::study {
namespace {

namespace fs = std::filesystem;
const SpecDefaults kShipped = SpecDefaults::shipped();

std::string what_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

std::string read(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// A copy of a shipped robot's folder in a fresh directory, with a study file beside it.
struct RobotCopy {
  fs::path dir;
  explicit RobotCopy(const std::string& robot, const std::string& tag) {
    dir = fs::temp_directory_path() / ("cpgmatch-study-robot-" + tag + "-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir / "mybot");
    for (const char* f : {"robot.yaml", "robot.urdf"}) fs::copy_file(shipped_robots_dir() / robot / f, dir / "mybot" / f);
  }
  ~RobotCopy() { fs::remove_all(dir); }
  void replace(const char* file, const std::string& from, const std::string& to) const {
    std::string text = read(dir / "mybot" / file);
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    std::ofstream(dir / "mybot" / file) << text;
  }
  std::string study_path() const { return (dir / "s.yaml").string(); }
};

TEST(StudyRobot, AShippedRobotsSpecHoldsItsDescriptionAndBuildsItsModelLegsAndSpace) {
  const StudySpec spec = StudySpec::resolve("name: dog\nrobot: odrive-quadruped\n", "s.yaml", kShipped);
  const RobotDescription robot = load_robot("odrive-quadruped");
  ASSERT_TRUE(spec.robot().has_value());
  EXPECT_EQ(spec.robot()->name, "odrive-quadruped");
  EXPECT_EQ(spec.config().robot, "odrive-quadruped");
  EXPECT_EQ(spec.tree()["robot"]["urdf"], robot.urdf_text);
  EXPECT_EQ(spec.tree()["robot"]["robot_yaml"], robot.yaml_text);
  EXPECT_FALSE(spec.tree().contains("model"));
  // The model is the description's, not Morti's.
  const sim::PlanarLegModel expected = sim::planar_leg_model(robot);
  EXPECT_EQ(spec.model().trunk_mass_kg, expected.trunk_mass_kg);
  EXPECT_NE(spec.model().trunk_mass_kg, sim::load_model_file(kShipped.model_path).trunk_mass_kg);
  EXPECT_EQ(spec.model().hip_positions_m(), expected.hip_positions_m());
  // Its search space and its default preset as the base.
  ASSERT_EQ(spec.config().space.size(), static_cast<int>(robot.search_space.size()));
  for (const SearchParameter& p : robot.search_space) {
    const int d = spec.config().space.index_of(p.name);
    ASSERT_GE(d, 0) << p.name;
    EXPECT_EQ(spec.config().space.dimensions()[static_cast<std::size_t>(d)].high, p.high);
  }
  const auto base = to_map(spec.base_parameters());
  for (const auto& [name, value] : robot.presets.at("default")) EXPECT_EQ(base.at(name), value) << name;
  EXPECT_EQ(spec.rollout_settings().controller.legs.size(), robot.legs.size());
}

TEST(StudyRobot, AWorkerRunsTheRobotFromTheSpecAloneAsRolloutDashRobotDoes) {
  const StudySpec submitted = StudySpec::resolve("name: hex\nrobot: moteus-hexapod\nseed: 2\n", "s.yaml", kShipped);
  const StudySpec received = StudySpec::from_json_text(submitted.canonical_json(), "received");
  EXPECT_EQ(received.sha256(), submitted.sha256());
  const sim::SimRolloutJob job = sim_job_for(received, {}, "flat", trial_seed(received, 0), 1.0, 2.0);
  // The same rollout set up by hand from the robot, as `cpgmatch eval-rollout --robot` does.
  const RobotDescription robot = load_robot("moteus-hexapod");
  sim::SimRolloutJob by_hand;
  by_hand.settings = load_rollout_settings(sim::default_rollout_settings_path());
  by_hand.params = load_parameters(sim::default_params_path());
  by_hand.model = sim::planar_leg_model(robot);
  apply_robot_legs(by_hand.settings.controller, robot);
  for (const auto& [key, value] : robot.presets.at("default")) set_parameter(by_hand.params, key, value, "preset");
  by_hand.settings.entrain_s = 1.0;
  by_hand.settings.eval_s = 2.0;
  by_hand.terrain = job.terrain;
  by_hand.seed = job.seed;
  ASSERT_EQ(job.settings.controller.legs.size(), 6u);
  const RolloutResult a = sim::run_sim_rollout(job);
  const RolloutResult b = sim::run_sim_rollout(by_hand);
  EXPECT_EQ(a.cost, b.cost);
  EXPECT_EQ(a.fell, b.fell);
  EXPECT_GT(a.sim_time_s, 2.9);
}

TEST(StudyRobot, ARobotOfTheUsersOwnTravelsWithTheStudyAndItsContentIsItsHash) {
  RobotCopy copy("odrive-quadruped", "own");
  const std::string study = "name: mine\nrobot: mybot/robot.yaml\n";
  const std::string sent = with_named_files(study, copy.study_path());
  EXPECT_NE(sent.find(kRobotUrdfTextKey), std::string::npos);
  const StudySpec spec = StudySpec::resolve(sent, copy.study_path(), kShipped);
  EXPECT_EQ(spec.robot()->name, "odrive-quadruped");  // its robot.yaml's name, not the path
  EXPECT_EQ(spec.tree()["study"]["robot"], "odrive-quadruped");
  // The same robot shipped: the same content, the same spec.
  EXPECT_EQ(spec.sha256(), StudySpec::resolve("name: mine\nrobot: odrive-quadruped\n", "s", kShipped).sha256());
  // The folder works as well as its robot.yaml.
  EXPECT_EQ(StudySpec::resolve(with_named_files("name: mine\nrobot: mybot\n", copy.study_path()), "s", kShipped).sha256(),
            spec.sha256());
  // One mass changed in the URDF: another experiment, another hash, another model.
  const std::string urdf = read(copy.dir / "mybot" / "robot.urdf");
  const auto at = urdf.find("<mass value=\"");
  ASSERT_NE(at, std::string::npos);
  const auto end = urdf.find('"', at + 13);
  copy.replace("robot.urdf", urdf.substr(at, end - at + 1), "<mass value=\"2.5\"");
  const StudySpec heavier = StudySpec::resolve(with_named_files(study, copy.study_path()), "s", kShipped);
  EXPECT_NE(heavier.sha256(), spec.sha256());
  // Its study file resubmits to the same spec, with no file beside it.
  EXPECT_EQ(StudySpec::resolve(heavier.to_study_yaml(), "again", kShipped).sha256(), heavier.sha256());
}

TEST(StudyRobot, BadRobotsAreRefusedNamingTheFieldAndTheRobotsOwnLine) {
  EXPECT_NE(what_of([] { StudySpec::resolve("name: s\nrobot: cheetah\n", "s.yaml", kShipped); })
                .find("s.yaml:2: field 'robot': 'cheetah' is not a shipped robot (shipped: "),
            std::string::npos);
  // The optimizer never reads a path a client names: only what the client sent.
  EXPECT_NE(what_of([] { StudySpec::resolve("name: s\nrobot: /etc/robot.yaml\n", "s.yaml", kShipped); }).find("is not a shipped robot"),
            std::string::npos);
  EXPECT_NE(what_of([] { StudySpec::resolve("name: s\nrobot: morti\nmodel: {trunk_mass_kg: 3}\n", "s.yaml", kShipped); })
                .find("s.yaml:3: field 'model': a study of robot 'morti' takes its model from the robot's description"),
            std::string::npos);
  EXPECT_NE(what_of([] { StudySpec::resolve("name: s\nrobot: morti\nrobot_urdf_text: \"<robot/>\"\n", "s.yaml", kShipped); })
                .find("robot_urdf_text"),
            std::string::npos);
  RobotCopy copy("odrive-quadruped", "bad");
  copy.replace("robot.yaml", "hip: FL_hip,", "hip: FL_hip_joint,");
  const std::string e = what_of([&] { (void)with_named_files("name: s\nrobot: mybot\n", copy.study_path()); });
  EXPECT_NE(e.find("s.yaml:2: field 'robot': "), std::string::npos) << e;
  EXPECT_NE(e.find("robot.yaml:"), std::string::npos) << e;
  EXPECT_NE(e.find("FL_hip_joint"), std::string::npos) << e;
  EXPECT_NE(what_of([&] { (void)with_named_files("name: s\nrobot: nothere/robot.yaml\n", copy.study_path()); })
                .find("s.yaml:2: field 'robot'"),
            std::string::npos);
}

TEST(StudyRobot, AStudyWithoutARobotIsMortisModelFileAsBefore) {
  const StudySpec spec = StudySpec::resolve("name: plain\n", "s.yaml", kShipped);
  EXPECT_FALSE(spec.robot().has_value());
  EXPECT_TRUE(spec.tree().contains("model"));
  EXPECT_FALSE(spec.tree().contains("robot"));
}

TEST(StudyRobot, AnAgentWhoseBodyIsAnotherRobotsRefusesTheStudyWithTheReason) {
  const fs::path configs = shipped_robots_dir().parent_path() / "robot";
  const robot::RobotConfig morti_body = robot::load_robot_config((configs / "morti.yaml").string());
  const robot::RobotConfig dog_body = robot::load_robot_config((configs / "odrive-quadruped.yaml").string());
  const robot::RobotConfig hexapod_body = robot::load_robot_config((configs / "moteus-hexapod.yaml").string());
  const RobotDescription morti = load_robot("morti"), dog = load_robot("odrive-quadruped"), hexapod = load_robot("moteus-hexapod");
  EXPECT_EQ(morti_body.study_robot_mismatch(morti), std::nullopt);
  EXPECT_EQ(dog_body.study_robot_mismatch(dog), std::nullopt);
  EXPECT_EQ(hexapod_body.study_robot_mismatch(hexapod), std::nullopt);
  // Same joint names (FL_hip ... HR_knee), other robot: its name and protocol say so.
  const auto why = morti_body.study_robot_mismatch(dog);
  ASSERT_TRUE(why.has_value());
  EXPECT_NE(why->find("the study is for robot 'odrive-quadruped'; this agent drives 'morti'"), std::string::npos) << *why;
  EXPECT_NE(why->find("protocol mit"), std::string::npos) << *why;
  // A hardware file that names no robot is compared by its joints: six legs are not four.
  robot::RobotConfig unnamed = morti_body;
  unnamed.robot.clear();
  EXPECT_EQ(unnamed.study_robot_mismatch(morti), std::nullopt);
  const auto legs = unnamed.study_robot_mismatch(hexapod);
  ASSERT_TRUE(legs.has_value());
  EXPECT_NE(legs->find("the study's robot 'moteus-hexapod' has 6 legs"), std::string::npos) << *legs;
  EXPECT_NE(legs->find("4 legs"), std::string::npos) << *legs;
}

}  // namespace
}  // namespace cpgmatch::study
