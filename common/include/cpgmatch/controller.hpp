// The closed-loop CPG controller: oscillator network + trajectory shaping + per-leg elastic feedback.
//
// One update() per control tick (500 Hz on Morti) turns the latest binary contacts into joint commands.
// The controller knows nothing about physics engines or motor buses; it only sees contacts and time.
#pragma once

#include "cpgmatch/cpg.hpp"
#include "cpgmatch/feedback.hpp"
#include "cpgmatch/plant.hpp"

namespace cpgmatch {

struct ControllerConfig {
  std::string gait = "trot";  // a name of `gaits` (or, with none given, of Gait::named's quadruped gaits)
  // The robot's legs and its gaits (one phase offset per leg), from its description. The defaults are
  // Morti's four legs and the quadruped gaits of Gait::named.
  LegLayout legs = LegLayout::quadruped();
  std::vector<Gait> gaits;
  double coupling_gain_per_s = 0.5;  // K in the oscillator equation
  double control_rate_hz = 500.0;
  // The CPG amplitudes ramp from 0 to their full value over this time, so a rollout starts from
  // standing still instead of with a jump in the joint targets.
  double startup_ramp_s = 1.0;
  FeedbackConfig feedback;
};

// The gait `config.gait` names among `config.gaits` (Gait::named's when that is empty), checked to have one
// offset per leg of `config.legs`; InputError naming the gaits there are otherwise.
Gait resolve_gait(const ControllerConfig& config);

struct ControllerOutput {
  PerLeg<JointCommand> commands;
  PerLeg<FeedbackActivity> activity;
  PerLeg<double> phases;
};

class CpgController {
 public:
  CpgController(const CpgParameters& params, const ControllerConfig& config);

  // Advances the controller by one control period using the contacts polled most recently (one per leg).
  ControllerOutput update(const PerLeg<bool>& contacts);
  std::size_t leg_count() const { return config_.legs.size(); }

  double time_s() const { return time_s_; }
  const PhaseOscillatorNetwork& network() const { return network_; }
  const CpgParameters& params() const { return params_; }
  double control_period_s() const { return 1.0 / config_.control_rate_hz; }

 private:
  CpgParameters params_;
  ControllerConfig config_;
  PhaseOscillatorNetwork network_;
  PerLeg<LegFeedback> feedback_;
  PerLeg<StepTiming> timing_;
  // The gait moves this leg and its girdle partner half a cycle apart (trot, pace, walk), so one of them is
  // meant to carry the girdle while the other swings; not in a bound or a pronk (the reflex's girdle gate).
  PerLeg<bool> girdle_alternates_;
  PerLeg<int> girdle_partner_;  // -1: the leg's group is not a pair
  double time_s_ = 0.0;
};

}  // namespace cpgmatch
