#include "cpgmatch/controller.hpp"

#include <algorithm>
#include <cmath>

namespace cpgmatch {

CpgController::CpgController(const CpgParameters& params, const ControllerConfig& config)
    : params_(params),
      config_(config),
      network_(Gait::named(config.gait), config.coupling_gain_per_s) {
  for (int leg = 0; leg < kNumLegs; ++leg) {
    feedback_[leg] = LegFeedback(config.feedback);
    timing_[leg] = step_timing(params, leg);
    const double apart = std::fmod(std::abs(network_.gait().phase_offsets[leg] -
                                            network_.gait().phase_offsets[girdle_partner(leg)]), 1.0);
    girdle_alternates_[leg] = std::abs(apart - 0.5) < 0.25;
  }
}

ControllerOutput CpgController::update(const PerLeg<bool>& contacts) {
  const double dt = control_period_s();
  const double ramp = config_.startup_ramp_s > 0.0 ? std::clamp(time_s_ / config_.startup_ramp_s, 0.0, 1.0) : 1.0;

  ControllerOutput out;
  PerLeg<double> rates{};
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const double phase = network_.phases()[leg];
    const StepTiming& timing = timing_[leg];
    // In a bound or a pronk both legs of a girdle swing together: the partner's contact says nothing about
    // whether the girdle is carried, so it is treated as carried (the reflex is not gated).
    const bool girdle_carried = !girdle_alternates_[leg] || contacts[girdle_partner(leg)];
    const FeedbackAction action = feedback_[leg].update(phase, contacts[leg], dt, timing, girdle_carried);
    // No phase deceleration during the start-up ramp: the feet are all down while standing.
    rates[leg] = ramp < 1.0 ? 1.0 : action.phase_rate;

    const double flex_start = action.knee_flex_start >= 0.0 ? action.knee_flex_start : timing.knee_flex_start;
    JointCommand& cmd = out.commands[leg];
    cmd.hip_angle_rad = params_.hip_offset * ramp +
                        ramp * params_.hip_amplitude * hip_profile(phase, timing.duty_factor, params_.overswing);
    cmd.knee_flexion_rad = ramp * params_.knee_amplitude * knee_profile(phase, flex_start, timing.retraction_start) +
                           action.extra_knee_flexion;
    cmd.hip_passive = action.hip_passive;
    out.activity[leg] = ramp < 1.0 ? FeedbackActivity{} : action.activity;
    out.phases[leg] = phase;
  }
  network_.step(dt, params_.frequency, rates);
  time_s_ += dt;
  return out;
}

}  // namespace cpgmatch
