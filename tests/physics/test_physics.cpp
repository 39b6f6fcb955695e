// Physics tests on the ODE model: the robot stands, the matched trot walks, moving the ground makes the
// right feedback fire, and rollouts are deterministic.
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/sim/ode_plant.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"

namespace cpgmatch::sim {
namespace {

SimRolloutJob job_with(const std::string& params_file, const std::string& terrain, double entrain, double eval) {
  SimRolloutJob job;
  job.params = load_parameters(params_file.empty() ? default_params_path() : config_dir() + "/params/" + params_file);
  job.settings = load_rollout_settings(default_rollout_settings_path());
  job.settings.entrain_s = entrain;
  job.settings.eval_s = eval;
  job.model = load_morti_model(default_model_path());
  job.terrain = TerrainSpec::parse(terrain);
  return job;
}

TEST(Physics, StandingRobotStaysUpOnItsSprings) {
  SimRolloutJob job = job_with("", "flat", 0.0, 5.0);
  job.params.hip_amplitude = 0.0;
  job.params.knee_amplitude = 0.0;
  job.params.hip_offset = -0.1;  // toes under the hips
  double min_height = 1.0, max_abs_pitch = 0.0, final_height = 0.0, final_x = 0.0;
  const RolloutResult r = run_sim_rollout(job, [&](const TraceSample& s) {
    if (s.time_s < 1.0) return;  // settling on the springs
    min_height = std::min(min_height, s.state->trunk.height_m);
    max_abs_pitch = std::max(max_abs_pitch, std::abs(s.state->trunk.pitch_rad));
    final_height = s.state->trunk.height_m;
    final_x = s.state->trunk.x_m;
  });
  EXPECT_FALSE(r.fell);
  // Standing hip height is 0.285 m unloaded; the springs may give a few centimetres, not collapse.
  EXPECT_GT(min_height, 0.22);
  EXPECT_LT(final_height, 0.29);  // loaded springs do compress
  EXPECT_LT(max_abs_pitch, 0.1);
  EXPECT_LT(std::abs(final_x), 0.05);
}

TEST(Physics, MatchedTrotWalksForwardFor20SecondsWithoutFalling) {
  const RolloutResult r = run_sim_rollout(job_with("matched-trot.yaml", "flat", 10.0, 10.0));
  EXPECT_FALSE(r.fell);
  EXPECT_GE(r.breakdown.mean_speed_mps, 0.25);
  EXPECT_GT(r.breakdown.distance_m, 2.5);
}

TEST(Physics, FeedbackKeepsTheMatchedTrotUp) {
  SimRolloutJob job = job_with("matched-trot.yaml", "flat", 10.0, 10.0);
  job.settings.controller.feedback = FeedbackConfig::none();
  EXPECT_TRUE(run_sim_rollout(job).fell);  // the same gait open loop falls
}

// Feedback activity of one mechanism, summed over legs, in the half second after `from_s`.
int activity_after(const SimRolloutJob& job, double from_s, bool FeedbackActivity::*mechanism) {
  int ticks = 0;
  run_sim_rollout(job, [&](const TraceSample& s) {
    if (s.time_s < from_s || s.time_s >= from_s + 0.5) return;
    for (int leg = 0; leg < kNumLegs; ++leg) ticks += s.output->activity[leg].*mechanism;
  });
  return ticks;
}

TEST(Physics, LoweringTheGroundMakesLateTouchdownFire) {
  // Identical rollouts until t = 3 s; then the ground drops 2 cm under the walking robot.
  const int moved = activity_after(job_with("matched-trot.yaml", "shift:-0.02@3.0", 3.0, 1.0), 3.0,
                                   &FeedbackActivity::late_touchdown);
  const int still = activity_after(job_with("matched-trot.yaml", "shift:0.0@3.0", 3.0, 1.0), 3.0,
                                   &FeedbackActivity::late_touchdown);
  EXPECT_GT(moved, still);
}

TEST(Physics, RaisingTheGroundMakesEarlyTouchdownFire) {
  const int moved = activity_after(job_with("matched-trot.yaml", "shift:0.03@3.0", 3.0, 1.0), 3.0,
                                   &FeedbackActivity::early_touchdown);
  const int still = activity_after(job_with("matched-trot.yaml", "shift:0.0@3.0", 3.0, 1.0), 3.0,
                                   &FeedbackActivity::early_touchdown);
  EXPECT_GT(moved, still);
}

TEST(Physics, SameSeedSameResultDifferentRoughGroundDifferentResult) {
  SimRolloutJob a = job_with("matched-trot.yaml", "rough:0.005", 2.0, 3.0);
  a.settings.contact_sensor.noise_std_n = 0.5;
  a.seed = 42;
  SimRolloutJob b = a;
  SimRolloutJob c = a;
  c.seed = 43;
  const RolloutResult ra = run_sim_rollout(a), rb = run_sim_rollout(b), rc = run_sim_rollout(c);
  EXPECT_EQ(ra.cost, rb.cost);
  EXPECT_EQ(ra.breakdown.distance_m, rb.breakdown.distance_m);
  EXPECT_EQ(ra.breakdown.normalized_torque, rb.breakdown.normalized_torque);
  EXPECT_NE(ra.breakdown.distance_m, rc.breakdown.distance_m);
}

TEST(Physics, OnGentlyRoughGroundFeedbackFallsNoMoreOftenThanOpenLoop) {
  int falls_with = 0, falls_without = 0;
  for (std::uint64_t seed = 0; seed < 4; ++seed) {
    SimRolloutJob job = job_with("matched-trot.yaml", "rough:0.003", 10.0, 10.0);
    job.seed = seed;
    falls_with += run_sim_rollout(job).fell;
    job.settings.controller.feedback = FeedbackConfig::none();
    falls_without += run_sim_rollout(job).fell;
  }
  EXPECT_LE(falls_with, falls_without);
}

TEST(Physics, OnATreadmillTheMatchedTrotWalksTheBeltAndStaysNearItsStart) {
  SimRolloutJob job = job_with("matched-trot.yaml", "flat", 10.0, 10.0);
  job.terrain.treadmill_speed_mps = 0.3;
  double world_x_end = 0.0;
  const RolloutResult r = run_sim_rollout(job, [&](const TraceSample& s) {
    // Ground distance minus the belt's travel (the belt ramps up over 2 s) is where the trunk is.
    const double belt = 0.3 * std::max(0.0, s.time_s - 1.0);
    world_x_end = s.state->trunk.x_m - belt;
  });
  EXPECT_FALSE(r.fell);
  EXPECT_GE(r.breakdown.mean_speed_mps, 0.25);  // speed over the belt, as on fixed ground
  EXPECT_LT(std::abs(world_x_end), 0.5);        // the belt holds the body near its start
}

TEST(Physics, ModelFileErrorsNameFileLineAndField) {
  const std::string path = ::testing::TempDir() + "/bad_model.yaml";
  {
    std::ofstream f(path);
    f << "trunk:\n  mass_kg: {value: -3.0}\n";
  }
  try {
    (void)load_morti_model(path);
    FAIL() << "expected InputError";
  } catch (const cpgmatch::InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("bad_model.yaml:2"), std::string::npos) << msg;
    EXPECT_NE(msg.find("trunk.mass_kg"), std::string::npos) << msg;
  }
}

}  // namespace
}  // namespace cpgmatch::sim
