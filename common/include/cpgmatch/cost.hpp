// The paper's cost, eqs. (2)-(7), and its energy measure, eq. (1).
//
//   J = w_fb J_feedback + w_d J_distance + w_p J_pitch + w_c J_contact + w_per J_periodicity
//
// J_feedback    fraction of the evaluation time during which feedback is active, averaged over legs and
//               summed over the four mechanisms (eq. 2: active time per step cycle and leg).
// J_distance    1 / x_body, x_body the distance walked during the evaluation, metres (eq. 3). x_body is
//               floored at CostConfig::min_distance_m so standing still or walking backwards gives a
//               large finite value instead of infinity or a negative cost.
// J_pitch       mean over strides (windows of 1/f) of max pitch minus mean of min pitch, radians (eq. 4).
// J_contact     extra contact phases per step and leg (eq. 5). The paper's printed formula counts every
//               flight/stance change, which is 2 per leg and step even for a perfect gait (8 for four
//               legs), yet it reports 0.03 for good gaits; we therefore count only the changes beyond the
//               two a clean step has, divided by two: one stumble or drag per step and leg gives 1.
// J_periodicity |f_pitch - f_expected| in hertz, f_pitch the peak of the body-pitch spectrum (eqs. 6-7,
//               N = 1). The paper compares with f_cpg, but body pitch repeats at f_cpg only for gaits whose
//               front and hind legs alternate (bound, pronk); in a trot, pace or walk both front legs (and
//               both hind legs) take one step each per cycle half a cycle apart, so a clean gait pitches
//               at 2 f_cpg (see pitch_harmonic() in cpg.hpp). f_expected = harmonic x f_cpg, so a clean
//               trot scores ~0 as the paper's good gaits do (0.0 in its Supplementary Table 3).
//
// Every term saturates at a cap (CostConfig::caps()) so the cost of any rollout that did not fall is
// bounded: J_feedback <= 4 (four fractions of time), J_distance <= 1/min_distance_m, J_pitch <= 2 x the
// fall pitch (pitch beyond it is a fall), J_contact <= contact_cap, J_periodicity <= f_expected (a peak
// that far off is no periodicity at all). A fall costs that bound plus a margin, so every fall costs more
// than every rollout that did not fall, standing still included.
//
// Normalised torque, eq. (1): sum over legs of (mean |hip torque| + mean |knee torque|) divided by the
// mean forward speed. Mean *absolute* torque, because the signed mean of an oscillating torque is ~0.
//
// A fall (|pitch| or trunk height beyond limits) ends the rollout early and replaces the cost by
// non_fall_bound() + fall_cost_margin + fall_cost_per_lost_fraction * (fraction of the rollout lost), so that
// a later fall is still a little better than an early one, and any fall is worse than any non-fall.
#pragma once

#include <array>
#include <vector>

#include "cpgmatch/feedback.hpp"
#include "cpgmatch/legs.hpp"

namespace cpgmatch {

struct CostWeights {
  double feedback = 1.0;
  double distance = 1.0;
  double pitch = 1.0;
  double contact = 1.0;
  double periodicity = 1.0;
};

struct CostConfig {
  CostWeights weights;
  // Floor on x_body for J_distance. Below 0.25 m in a 10-s evaluation (2.5 cm/s, a tenth of the paper's
  // 0.3 m/s) the trunk sways in place rather than walks; all such rollouts are equally "no gait", so
  // J_distance saturates at 4 1/m instead of growing without bound (0.05 m gave 20 1/m: standing still
  // then cost more than a fall).
  double min_distance_m = 0.25;
  double contact_cap = 2.0;              // J_contact saturates at two extra contact phases per step and leg
  double fall_max_abs_pitch_rad = 0.8;   // about 46 degrees; a free robot's roll too (a tilt either way)
  double fall_min_height_m = 0.10;       // trunk centre below this is a fall
  double fall_cost_margin = 1.0;         // a fall costs at least this much more than the non-fall bound
  double fall_cost_per_lost_fraction = 5.0;

  // The largest cost a rollout that did not fall can have, for a gait of expected pitch frequency f_pitch.
  double non_fall_bound(double expected_pitch_hz) const;
};

struct CostTerms {
  double feedback = 0.0;
  double distance = 0.0;
  double pitch = 0.0;
  double contact = 0.0;
  double periodicity = 0.0;
};

struct FeedbackFractions {
  double late_touchdown = 0.0;
  double early_touchdown = 0.0;
  double early_toeoff = 0.0;
  double late_toeoff = 0.0;
};

struct CostBreakdown {
  double cost = 0.0;
  CostTerms terms;
  FeedbackFractions feedback_fraction;  // per mechanism, fraction of time averaged over legs
  double normalized_torque = 0.0;       // N m / (m/s)
  double summed_torque_nm = 0.0;        // eq. (1)'s numerator: sum over joints of the mean |torque|, N m
  double distance_m = 0.0;
  double mean_speed_mps = 0.0;
};

// One evaluation-window sample, recorded at the control rate.
struct CostSample {
  double time_s = 0.0;
  double x_m = 0.0;
  double pitch_rad = 0.0;
  PerLeg<bool> contact;  // one per leg, every sample of a recorder with the same number
  PerLeg<FeedbackActivity> activity;
  PerLeg<double> abs_hip_torque_nm;
  PerLeg<double> abs_knee_torque_nm;
};

class CostRecorder {
 public:
  explicit CostRecorder(CostConfig config) : config_(config) {}
  // Room for this many samples, taken before a rollout's loop so that add() never allocates inside it.
  void reserve(std::size_t samples) { samples_.reserve(samples); }
  void add(const CostSample& sample) { samples_.push_back(sample); }
  std::size_t size() const { return samples_.size(); }

  // Evaluates every term over the recorded window. `cpg_frequency_hz` is f in eqs. (2) and (5);
  // `expected_pitch_hz` is what eq. (7) compares the pitch peak with (pitch_harmonic x f).
  CostBreakdown evaluate(double cpg_frequency_hz, double expected_pitch_hz) const;

  // The cost of a fall at `fall_time_s` in a rollout of `total_time_s`.
  double fall_cost(double fall_time_s, double total_time_s, double expected_pitch_hz) const;

 private:
  CostConfig config_;
  std::vector<CostSample> samples_;
};

// Individual terms on plain inputs, exposed for tests and for offline analysis of hardware logs.
double pitch_range_term(const std::vector<double>& pitch_rad, double sample_rate_hz, double stride_frequency_hz);
double dominant_frequency_hz(const std::vector<double>& signal, double sample_rate_hz);
double periodicity_term(const std::vector<double>& pitch_rad, double sample_rate_hz, double expected_pitch_hz);
double contact_term(const std::vector<PerLeg<bool>>& contacts, double sample_rate_hz, double cpg_frequency_hz);

}  // namespace cpgmatch
