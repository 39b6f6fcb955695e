// Robot overlays (common/robot_description/src/robot_overlay.hpp): the reality-gap scenarios as overlays on
// Morti's description equal their model files value for value and rollout for rollout, and every bad
// overlay is refused naming the overlay's own line.
#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/sim/planar_leg_model.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "model_equality.hpp"

namespace cpgmatch {
namespace {

namespace fs = std::filesystem;

const char* const kScenarios[] = {"battery-trunk", "late-foottiles", "slippery-belt", "stiff-gearbox", "worn-knee-spring"};

fs::path scenario_path(const std::string& name) { return shipped_robots_dir() / "morti" / "scenarios" / (name + ".yaml"); }
fs::path model_file_path(const std::string& name) { return fs::path(sim::default_model_path()).parent_path() / (name + ".yaml"); }

TEST(RobotOverlay, EachRealityGapScenarioIsItsModelFileValueForValue) {
  const sim::PlanarLegModel morti = sim::planar_leg_model(load_robot("morti"));
  for (const std::string name : kScenarios) {
    SCOPED_TRACE(name);
    const RobotDescription robot = load_robot(scenario_path(name).string());
    EXPECT_EQ(robot.name, "morti") << "a worn Morti is still Morti: its agent drives it";
    const sim::PlanarLegModel overlay = sim::planar_leg_model(robot);
    const sim::PlanarLegModel model_file = sim::load_model_file(model_file_path(name).string());
    testing_support::expect_models_equal(overlay, model_file);
    // The spec carries the merged texts: parsed again, they are the same robot.
    const RobotDescription reparsed = parse_robot(robot.yaml_text, robot.yaml_source, robot.urdf_text, robot.urdf_source);
    testing_support::expect_models_equal(sim::planar_leg_model(reparsed), model_file);
  }
  // And each is another robot than Morti (were the overlay ignored, the comparisons above would fail too).
  EXPECT_EQ(sim::planar_leg_model(load_robot(scenario_path("worn-knee-spring").string())).knee_spring.stiffness_nm_per_rad, 12.0);
  EXPECT_EQ(morti.knee_spring.stiffness_nm_per_rad, 15.0);
}

TEST(RobotOverlay, ALinksMassScalesTheUrdfLinksInertiaAndTheTotal) {
  const RobotDescription morti = load_robot("morti");
  const RobotDescription heavy = load_robot(scenario_path("battery-trunk").string());
  EXPECT_DOUBLE_EQ(heavy.link("trunk").mass_kg, 3.5);
  EXPECT_NEAR(heavy.total_mass_kg(), morti.total_mass_kg() + 0.5, 1e-12);
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_NEAR(heavy.link("trunk").inertia_kg_m2[i], morti.link("trunk").inertia_kg_m2[i] * 3.5 / 3.0, 1e-15) << i;
  }
  EXPECT_EQ(heavy.link("FL_femur").mass_kg, morti.link("FL_femur").mass_kg);
}

TEST(RobotOverlay, RolloutsEqualTheModelFilesOnThePresets) {
  const RobotDescription morti = load_robot("morti");
  for (const std::string name : kScenarios) {
    SCOPED_TRACE(name);
    sim::SimRolloutJob by_file;
    by_file.settings = load_rollout_settings(sim::default_rollout_settings_path());
    by_file.settings.entrain_s = 3.0;
    by_file.settings.eval_s = 3.0;
    by_file.model = sim::load_model_file(model_file_path(name).string());
    sim::SimRolloutJob by_overlay = by_file;
    by_overlay.model = sim::planar_leg_model(load_robot(scenario_path(name).string()));
    for (const char* preset : {"matched-trot", "unmatched"}) {
      for (const auto& [key, value] : morti.presets.at(preset)) set_parameter(by_file.params, key, value, preset);
      by_overlay.params = by_file.params;
      const RolloutResult a = sim::run_sim_rollout(by_file);
      const RolloutResult b = sim::run_sim_rollout(by_overlay);
      EXPECT_NEAR(a.cost, b.cost, 1e-9 * std::max(1.0, a.cost)) << preset;
      EXPECT_EQ(a.fell, b.fell) << preset;
    }
  }
}

// ---- bad overlays: each names the overlay's line ----

class BadOverlay : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("cpgmatch-overlay-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) const {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  static std::string error_of(const std::string& path) {
    try {
      (void)load_robot(path);
    } catch (const InputError& e) {
      return e.what();
    }
    return "(accepted)";
  }
  fs::path dir_;
};

TEST_F(BadOverlay, APathTheBaseLacksNamesTheOverlaysLine) {
  const std::string p = write("a.yaml", "base: morti\nset:\n  drives.knee.stifness_nm_per_rad: 12.0\n");
  const std::string e = error_of(p);
  EXPECT_NE(e.find("a.yaml:3"), std::string::npos) << e;
  EXPECT_NE(e.find("has no 'drives.knee.stifness_nm_per_rad'"), std::string::npos) << e;
}

TEST_F(BadOverlay, AValueThatBreaksTheRobotNamesTheOverlaysLineAndTheReason) {
  const std::string p = write("b.yaml", "base: morti\nset:\n  contact.friction: 0.5\n  drives.knee.stiffness_nm_per_rad: -3.0\n");
  const std::string e = error_of(p);
  EXPECT_NE(e.find("b.yaml:4"), std::string::npos) << e;
  EXPECT_NE(e.find("set.drives.knee.stiffness_nm_per_rad"), std::string::npos) << e;
  EXPECT_NE(e.find("must be > 0"), std::string::npos) << e;
}

TEST_F(BadOverlay, ALinkTheUrdfLacksAndAnUnknownBaseAndACycleAreRefused) {
  const std::string link = error_of(write("c.yaml", "base: morti\nset:\n  links.batery.mass_kg: 0.3\n"));
  EXPECT_NE(link.find("c.yaml:3"), std::string::npos) << link;
  EXPECT_NE(link.find("is not a link of"), std::string::npos) << link;

  const std::string base = error_of(write("d.yaml", "# a robot we do not ship\nbase: marty\n"));
  EXPECT_NE(base.find("d.yaml:2"), std::string::npos) << base;
  EXPECT_NE(base.find("no shipped robot of that name"), std::string::npos) << base;

  write("e.yaml", "base: f.yaml\n");
  const std::string cycle = error_of(write("f.yaml", "base: e.yaml\n"));
  EXPECT_NE(cycle.find("is there a cycle of bases?"), std::string::npos) << cycle;

  const std::string unknown = error_of(write("g.yaml", "base: morti\nsett:\n  contact.friction: 0.5\n"));
  EXPECT_NE(unknown.find("g.yaml:"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("field 'sett': unknown key"), std::string::npos) << unknown;
}

TEST_F(BadOverlay, AnOverlayOnAnOverlayAddsItsValuesAndKeepsTheBasesOwn) {
  write("worn.yaml", "base: " + scenario_path("worn-knee-spring").string() + "\nset:\n  contact.friction: 0.45\n");
  const sim::PlanarLegModel both = sim::planar_leg_model(load_robot((dir_ / "worn.yaml").string()));
  EXPECT_EQ(both.knee_spring.stiffness_nm_per_rad, 12.0);
  EXPECT_EQ(both.contact.friction, 0.45);
}

}  // namespace
}  // namespace cpgmatch
