#include "cpgmatch/controller.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch {

Gait resolve_gait(const ControllerConfig& config) {
  Gait gait;
  if (config.gaits.empty()) {
    gait = Gait::named(config.gait);
  } else {
    const auto it = std::find_if(config.gaits.begin(), config.gaits.end(), [&](const Gait& g) { return g.name == config.gait; });
    if (it == config.gaits.end()) {
      std::string known;
      for (const Gait& g : config.gaits) known += (known.empty() ? "" : ", ") + g.name;
      throw InputError(fmt::format("gait '{}': the robot's gaits are {}", config.gait, known));
    }
    gait = *it;
  }
  if (gait.leg_count() != config.legs.size()) {
    throw InputError(fmt::format("gait '{}' has {} phase offsets for a robot of {} legs", gait.name, gait.leg_count(),
                                 config.legs.size()));
  }
  return gait;
}

CpgController::CpgController(const CpgParameters& params, const ControllerConfig& config)
    : params_(params), config_(config), network_(resolve_gait(config), config.coupling_gain_per_s) {
  const std::size_t n = config.legs.size();
  feedback_ = PerLeg<LegFeedback>(n, LegFeedback(config.feedback));
  timing_ = PerLeg<StepTiming>(n);
  girdle_alternates_ = PerLeg<bool>(n, false);
  girdle_partner_ = PerLeg<int>(n, -1);
  for (std::size_t leg = 0; leg < n; ++leg) {
    timing_[leg] = step_timing(params, config.legs, static_cast<int>(leg));
    if (const auto partner = config.legs.girdle_partner(static_cast<int>(leg))) {
      girdle_partner_[leg] = *partner;
      const double apart = std::fmod(std::abs(network_.gait().phase_offsets[leg] - network_.gait().phase_offsets[*partner]), 1.0);
      girdle_alternates_[leg] = std::abs(apart - 0.5) < 0.25;
    }
  }
}

ControllerOutput CpgController::update(const PerLeg<bool>& contacts) {
  const double dt = control_period_s();
  const double ramp = config_.startup_ramp_s > 0.0 ? std::clamp(time_s_ / config_.startup_ramp_s, 0.0, 1.0) : 1.0;

  const std::size_t n = leg_count();
  ControllerOutput out{PerLeg<JointCommand>(n), PerLeg<FeedbackActivity>(n), PerLeg<double>(n)};
  PerLeg<double> rates(n);
  for (std::size_t leg = 0; leg < n; ++leg) {
    const double phase = network_.phases()[leg];
    const StepTiming& timing = timing_[leg];
    // In a bound or a pronk both legs of a girdle swing together: the partner's contact says nothing about
    // whether the girdle is carried, so it is treated as carried (the reflex is not gated). A leg whose group
    // is not a pair has no girdle partner and is treated the same way.
    const bool girdle_carried = !girdle_alternates_[leg] || contacts[static_cast<std::size_t>(girdle_partner_[leg])];
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
