#include "cpgmatch/feedback.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace cpgmatch {

FeedbackConfig FeedbackConfig::none() {
  FeedbackConfig c;
  c.late_touchdown = false;
  c.early_touchdown = false;
  c.early_toeoff = false;
  c.late_toeoff_deceleration = false;
  return c;
}

LegFeedback::LegFeedback(FeedbackConfig config) : config_(config) {}

void LegFeedback::reset() {
  initialised_ = false;
  touched_down_ = lifted_off_ = reflex_used_ = false;
  airborne_s_ = last_flight_s_ = 0.0;
  was_contact_ = true;
  reflex_time_left_ = 0.0;
  reflex_withheld_ = false;
  early_flex_start_ = -1.0;
  late_touchdown_wait_s_ = 0.0;
}

bool LegFeedback::landing_ready(double phase, const StepTiming& timing) const {
  const double flex_start = early_flex_start_ >= 0.0 ? early_flex_start_ : timing.knee_flex_start;
  const double flex_end = timing.retraction_start;
  // Only the re-extension half of the knee's flexion bump: early in swing the knee is also nearly straight,
  // but there the leg is lifting (a contact there is a scuff, handled by etd_min_airborne_s).
  if (phase < 0.5 * (flex_start + flex_end) || phase >= flex_end) return false;
  return knee_profile(phase, flex_start, flex_end) < config_.etd_min_knee_flexion_fraction;
}

FeedbackAction LegFeedback::update(double phase, bool contact, double dt_s, const StepTiming& timing,
                                   bool girdle_carried) {
  const double duty = timing.duty_factor;
  if (!initialised_) {
    // Standing start: the feet are on the ground, so treat the current window as already touched down.
    initialised_ = true;
    last_phase_ = phase;
    touched_down_ = contact;
    lifted_off_ = !contact;
  }

  // Window transitions. A wrap (phase decreased) starts a new stance window; crossing the duty factor
  // starts the swing window.
  const bool wrapped = phase < last_phase_ - 0.5;
  const bool entered_swing = !wrapped && last_phase_ < duty && phase >= duty;
  if (entered_swing) {
    late_touchdown_wait_s_ = 0.0;
    lifted_off_ = !contact;
    reflex_used_ = false;
    touched_down_ = false;
  }
  if (wrapped) {
    early_flex_start_ = -1.0;
    late_touchdown_wait_s_ = 0.0;
    // Touchdown during retraction (before the wrap) counts as on time.
  }
  last_phase_ = phase;
  if (contact) {
    if (!was_contact_) last_flight_s_ = airborne_s_;
    airborne_s_ = 0.0;
  } else {
    airborne_s_ += dt_s;
  }
  was_contact_ = contact;

  FeedbackAction action;
  const bool in_stance = phase < duty;

  if (in_stance) {
    if (contact) touched_down_ = true;
    // Late touchdown: stance has begun, no ground yet.
    if (!touched_down_ && config_.late_touchdown) {
      // Always measured while the ground is missing (the mismatch), but the phase is held back only for
      // late_touchdown_max_wait_s: a body that is falling onto the leg meets the ground within that time;
      // after it, the other legs carry the body and waiting longer only splits the leg from its partners.
      action.activity.late_touchdown = true;
      if (late_touchdown_wait_s_ < config_.late_touchdown_max_wait_s) {
        action.phase_rate = std::min(action.phase_rate, config_.late_touchdown_phase_rate);
      }
      late_touchdown_wait_s_ += dt_s;
    }
    // Early toe-off: ground lost after touchdown, before the knee was due to flex.
    if (touched_down_ && !contact && config_.early_toeoff && phase < timing.knee_flex_start &&
        phase >= config_.eto_min_stance_fraction * duty && early_flex_start_ < 0.0) {
      early_flex_start_ = phase;
    }
    // The ground came back before the scheduled flexion: the leg is loaded again, cancel the early flexion.
    if (contact && early_flex_start_ >= 0.0 && phase < timing.knee_flex_start) early_flex_start_ = -1.0;
    if (early_flex_start_ >= 0.0 && phase < timing.knee_flex_start) {
      action.activity.early_toeoff = true;
    }
  } else {
    if (!contact) lifted_off_ = true;
    // On time: in retraction, or with the leg already re-extended for landing (see landing_ready()).
    const bool on_time = phase >= timing.retraction_start || landing_ready(phase, timing);
    if (contact && on_time) touched_down_ = true;
    // Late toe-off: still on the ground after the nominal toe-off, never lifted in between.
    if (contact && !lifted_off_) {
      action.activity.late_toeoff = true;
      if (config_.late_toeoff_deceleration) {
        action.phase_rate = std::min(action.phase_rate, config_.late_toeoff_phase_rate);
      }
    }
    // Early touchdown: touched again after a real flight (not a scuff just after toe-off), while the leg
    // was still shortened for ground clearance.
    if (contact && lifted_off_ && last_flight_s_ >= config_.etd_min_airborne_s && !on_time && !reflex_used_ &&
        config_.early_touchdown) {
      reflex_used_ = true;
      reflex_time_left_ = config_.reflex_duration_s;
      reflex_withheld_ = config_.reflex_needs_girdle_support && !girdle_carried;
    }
  }

  if (reflex_time_left_ > 0.0) {
    // Knee pull-up on a fixed half-sine trajectory; the hip lets the springs take the impact, then drives on.
    const double elapsed = config_.reflex_duration_s - reflex_time_left_;
    const double u = std::clamp(elapsed / config_.reflex_duration_s, 0.0, 1.0);
    if (!reflex_withheld_) {
      action.extra_knee_flexion = config_.reflex_knee_flexion_rad * std::sin(std::numbers::pi * u);
      action.hip_passive = config_.reflex_hip_passive && elapsed < config_.reflex_hip_passive_s;
    }
    action.activity.early_touchdown = true;
    reflex_time_left_ -= dt_s;
  }
  if (early_flex_start_ >= 0.0) action.knee_flex_start = early_flex_start_;
  return action;
}

}  // namespace cpgmatch
