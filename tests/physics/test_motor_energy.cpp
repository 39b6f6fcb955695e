// The motors on the ODE model: the knee motor obeys the same torque-speed line as the hip (the same motor
// in the model), and what a standing robot's motors spend is heat, not work.
#include <cmath>

#include <gtest/gtest.h>

#include "cpgmatch/sim/ode_plant.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "../support/morti_legs.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch::sim {
namespace {

struct KneeDrive {
  double torque_nm, speed_rad_s;
};

// A standing robot, settled for 1 s, then told to stretch all knees by 0.5 rad at once: lifting the body
// through the knee springs loads the knee motors while they run at their fastest.
std::vector<KneeDrive> knee_drives_while_lifting(const PlanarLegModel& model) {
  OdePlant plant(model, TerrainSpec{}, 1);
  PerLeg<JointCommand> stand(test::kNumLegs);
  for (auto& c : stand) c.hip_angle_rad = -0.1;  // toes under the hips
  plant.command(stand);
  const double dt = plant.time_step_s();
  for (int i = 0; i < 1000; ++i) plant.advance(dt);
  PerLeg<JointCommand> stretch = stand;
  for (auto& c : stretch) c.knee_flexion_rad = -0.5;
  plant.command(stretch);
  std::vector<KneeDrive> drives;
  for (int i = 0; i < 300; ++i) {
    plant.advance(dt);
    for (const auto& leg : plant.state().legs) drives.push_back({leg.knee_torque_nm, leg.knee_motor_speed_rad_s});
  }
  return drives;
}

TEST(MotorPhysics, TheKneeMotorRunsOnTheHipsTorqueSpeedLine) {
  const PlanarLegModel model = load_model_file(default_model_path());
  ASSERT_EQ(model.knee_motor.stall_torque_nm, model.hip_motor.stall_torque_nm);  // the same motor
  ASSERT_EQ(model.knee_motor.no_load_speed_rad_s, model.hip_motor.no_load_speed_rad_s);
  const DcMotorLine line{model.knee_motor.stall_torque_nm, model.knee_motor.no_load_speed_rad_s};
  int motoring = 0, on_line_under_load = 0;
  for (const KneeDrive& d : knee_drives_while_lifting(model)) {
    if (d.torque_nm * d.speed_rad_s <= 0.0) continue;  // braking or still: up to the stall torque
    ++motoring;
    // Never above the line: more torque leaves less speed.
    EXPECT_LE(std::abs(d.torque_nm), line.available_torque_nm(d.speed_rad_s) + 1e-9)
        << "torque " << d.torque_nm << " N m at " << d.speed_rad_s << " rad/s";
    // Loaded and running as fast as the line lets it: on the line, well below the no-load speed.
    if (std::abs(d.torque_nm) > 1.0 && std::abs(std::abs(d.torque_nm) - line.available_torque_nm(d.speed_rad_s)) < 1e-6) {
      ++on_line_under_load;
      EXPECT_LT(std::abs(d.speed_rad_s), 0.75 * line.no_load_speed_rad_s);
    }
  }
  EXPECT_GT(motoring, 100);
  // The line binds: a motor that ignored it would run at the no-load speed whatever it carried.
  EXPECT_GT(on_line_under_load, 20);
}

TEST(MotorPhysics, AStandingRobotsMotorsDoNoWorkButHeatAsTheirHeldTorqueSquared) {
  SimRolloutJob job;
  job.params = load_parameters(default_params_path());
  job.settings = load_rollout_settings(default_rollout_settings_path());
  job.settings.entrain_s = 2.0;
  job.settings.eval_s = 3.0;
  job.model = load_model_file(default_model_path());
  job.params.hip_amplitude = 0.0;
  job.params.knee_amplitude = 0.0;
  job.params.hip_offset = -0.1;
  const RolloutResult r = run_sim_rollout(job);
  ASSERT_FALSE(r.fell);
  const EnergyMeasures& e = r.energy;
  ASSERT_TRUE(std::isfinite(e.joule_loss_j));
  // The knees carry the body: a steady torque, held without motion.
  const double c = job.model.knee_motor.no_load_speed_rad_s / job.model.knee_motor.stall_torque_nm;
  double steady_heat = 0.0, knee_load = 0.0;
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const double tau = e.knee[leg].signed_mean_torque_nm;
    knee_load += std::abs(tau);
    steady_heat += tau * tau * c * job.settings.eval_s;
  }
  EXPECT_GT(knee_load, 1.0);  // 4 kg on four knee levers of ~0.1 m: several N m together
  double knee_heat = 0.0;
  for (int leg = 0; leg < kNumLegs; ++leg) knee_heat += e.knee[leg].joule_loss_j;
  EXPECT_NEAR(knee_heat, steady_heat, 0.05 * steady_heat);
  // Standing still is almost no work: under 2% of what the motors turn into heat.
  EXPECT_LT(e.positive_work_j, 0.02 * e.joule_loss_j);
  EXPECT_NEAR(e.electrical_j, e.joule_loss_j, 0.05 * e.joule_loss_j);
}

}  // namespace
}  // namespace cpgmatch::sim
