// How a rollout ends, told apart: a fall is the gait's doing and is learned from; a plant fault (a
// watchdog, the bus, an emergency stop) and a diverged simulation are not, and say what happened.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "cpgmatch/rollout.hpp"
#include "../support/morti_legs.hpp"

namespace cpgmatch {
namespace {

// A body that stands still at a given height and pitch; after `event_at_s` it faults, blows up or tips.
class ScriptedPlant final : public Plant {
 public:
  enum class Event { kNone, kFault, kNonFinite, kTip, kJump };
  ScriptedPlant(Event event, double event_at_s) : event_(event), event_at_s_(event_at_s) {}
  void command(const PerLeg<JointCommand>&) override {}
  void advance(double dt_s) override { t_ += dt_s; }
  PlantState state() const override {
    PlantState s;
    s.legs = PerLeg<LegState>(test::kNumLegs);
    s.time_s = t_;
    s.trunk.height_m = 0.28;
    s.trunk.x_m = 0.01 * t_;
    for (auto& leg : s.legs) leg.foot_normal_force_n = 10.0;
    if (t_ >= event_at_s_ && event_ == Event::kNonFinite) s.trunk.pitch_rad = std::numeric_limits<double>::quiet_NaN();
    if (t_ >= event_at_s_ && event_ == Event::kTip) s.trunk.pitch_rad = 0.002 * (t_ - event_at_s_) * 1000.0;  // 2 rad/s
    if (t_ >= event_at_s_ && event_ == Event::kJump) s.trunk.pitch_rad = 0.5;  // 0.5 rad within one 2-ms tick
    return s;
  }
  double time_step_s() const override { return 0.001; }
  std::optional<std::string> fault() const override {
    if (event_ == Event::kFault && t_ >= event_at_s_) return std::string("motor hip FL (node 3) silent for 12.0 ms");
    return std::nullopt;
  }

 private:
  Event event_;
  double event_at_s_;
  double t_ = 0.0;
};

RolloutResult run(ScriptedPlant::Event event) {
  ScriptedPlant plant(event, 0.5);
  RolloutSettings settings;
  settings.entrain_s = 0.5;
  settings.eval_s = 0.5;
  return run_rollout(plant, CpgParameters{}, settings, 1);
}

TEST(RolloutOutcome, AFaultOfThePlantEndsTheRolloutAsAPlantFaultNotAFall) {
  const RolloutResult r = run(ScriptedPlant::Event::kFault);
  EXPECT_EQ(r.outcome, RolloutOutcome::kPlantFault);
  EXPECT_NE(r.outcome_message.find("motor hip FL (node 3) silent"), std::string::npos) << r.outcome_message;
  EXPECT_NE(r.outcome_message.find("t = 0.50"), std::string::npos) << r.outcome_message;
  EXPECT_FALSE(r.fell);
  EXPECT_NEAR(r.sim_time_s, 0.5, 0.003);  // it ended at the fault
  EXPECT_STREQ(to_string(r.outcome), "plant_fault");
}

TEST(RolloutOutcome, ANonFiniteStateIsADivergenceNotAFall) {
  const RolloutResult r = run(ScriptedPlant::Event::kNonFinite);
  EXPECT_EQ(r.outcome, RolloutOutcome::kDiverged);
  EXPECT_NE(r.outcome_message.find("non-finite"), std::string::npos) << r.outcome_message;
  EXPECT_FALSE(r.fell);
  EXPECT_TRUE(std::isfinite(r.cost));  // a placeholder that keeps every report finite
  EXPECT_STREQ(to_string(r.outcome), "diverged");
}

TEST(RolloutOutcome, AFiniteStateThatMovesImpossiblyFastIsADivergence) {
  const RolloutResult r = run(ScriptedPlant::Event::kJump);
  EXPECT_EQ(r.outcome, RolloutOutcome::kDiverged);
  EXPECT_NE(r.outcome_message.find("rad/s"), std::string::npos) << r.outcome_message;
  EXPECT_FALSE(r.fell);
}

TEST(RolloutOutcome, TippingOverIsAFallAndAQuietRolloutCompletes) {
  const RolloutResult tipped = run(ScriptedPlant::Event::kTip);
  EXPECT_EQ(tipped.outcome, RolloutOutcome::kFell);
  EXPECT_TRUE(tipped.fell);
  EXPECT_TRUE(tipped.outcome_message.empty());
  const RolloutResult quiet = run(ScriptedPlant::Event::kNone);
  EXPECT_EQ(quiet.outcome, RolloutOutcome::kCompleted);
  EXPECT_FALSE(quiet.fell);
  EXPECT_NEAR(quiet.sim_time_s, 1.0, 1e-9);
}

}  // namespace
}  // namespace cpgmatch
