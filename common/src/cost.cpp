#include "cpgmatch/cost.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numeric>

#include <unsupported/Eigen/FFT>

namespace cpgmatch {

double pitch_range_term(const std::vector<double>& pitch_rad, double sample_rate_hz, double stride_frequency_hz) {
  const auto stride_len = static_cast<std::size_t>(std::llround(sample_rate_hz / stride_frequency_hz));
  if (stride_len == 0 || pitch_rad.size() < stride_len) {
    if (pitch_rad.empty()) return 0.0;
    const auto [lo, hi] = std::minmax_element(pitch_rad.begin(), pitch_rad.end());
    return *hi - *lo;
  }
  double sum_max = 0.0, sum_min = 0.0;
  std::size_t strides = 0;
  for (std::size_t start = 0; start + stride_len <= pitch_rad.size(); start += stride_len) {
    const auto [lo, hi] = std::minmax_element(pitch_rad.begin() + start, pitch_rad.begin() + start + stride_len);
    sum_max += *hi;
    sum_min += *lo;
    ++strides;
  }
  return std::abs(sum_max / strides - sum_min / strides);
}

double dominant_frequency_hz(const std::vector<double>& signal, double sample_rate_hz) {
  const std::size_t n = signal.size();
  if (n < 4) return 0.0;
  const double mean = std::accumulate(signal.begin(), signal.end(), 0.0) / n;
  // Hann window against leakage, zero padding x4 for a finer frequency grid.
  std::vector<double> padded(4 * n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    const double w = 0.5 - 0.5 * std::cos(2.0 * M_PI * i / (n - 1));
    padded[i] = (signal[i] - mean) * w;
  }
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> spectrum;
  fft.fwd(spectrum, padded);
  const std::size_t half = padded.size() / 2;
  std::size_t best = 1;
  double best_power = -1.0;
  for (std::size_t k = 1; k < half; ++k) {
    const double p = std::norm(spectrum[k]);
    if (p > best_power) {
      best_power = p;
      best = k;
    }
  }
  // Parabolic interpolation of the log-power peak for sub-bin accuracy.
  double offset = 0.0;
  if (best > 1 && best + 1 < half) {
    const double a = std::log(std::norm(spectrum[best - 1]) + 1e-300);
    const double b = std::log(best_power + 1e-300);
    const double c = std::log(std::norm(spectrum[best + 1]) + 1e-300);
    const double denom = a - 2.0 * b + c;
    if (denom < 0.0) offset = std::clamp(0.5 * (a - c) / denom, -0.5, 0.5);
  }
  return (best + offset) * sample_rate_hz / padded.size();
}

double periodicity_term(const std::vector<double>& pitch_rad, double sample_rate_hz, double expected_pitch_hz) {
  const double f_pitch = dominant_frequency_hz(pitch_rad, sample_rate_hz);
  return std::min(std::abs(f_pitch - expected_pitch_hz), expected_pitch_hz);
}

double contact_term(const std::vector<PerLeg<bool>>& contacts, double sample_rate_hz, double cpg_frequency_hz) {
  if (contacts.size() < 2) return 0.0;
  const double steps = cpg_frequency_hz * contacts.size() / sample_rate_hz;  // f * T
  const std::size_t legs = contacts.front().size();
  if (legs == 0) return 0.0;
  double extra = 0.0;
  for (std::size_t leg = 0; leg < legs; ++leg) {
    int changes = 0;
    for (std::size_t i = 1; i < contacts.size(); ++i) changes += contacts[i][leg] != contacts[i - 1][leg];
    extra += std::max(0.0, changes - 2.0 * steps);
  }
  return extra / (2.0 * static_cast<double>(legs) * steps);
}

double CostConfig::non_fall_bound(double expected_pitch_hz) const {
  return weights.feedback * 4.0 + weights.distance / min_distance_m + weights.pitch * 2.0 * fall_max_abs_pitch_rad +
         weights.contact * contact_cap + weights.periodicity * expected_pitch_hz;
}

double CostRecorder::fall_cost(double fall_time_s, double total_time_s, double expected_pitch_hz) const {
  const double lost = total_time_s > 0.0 ? std::clamp(1.0 - fall_time_s / total_time_s, 0.0, 1.0) : 1.0;
  return config_.non_fall_bound(expected_pitch_hz) + config_.fall_cost_margin +
         config_.fall_cost_per_lost_fraction * lost;
}

CostBreakdown CostRecorder::evaluate(double cpg_frequency_hz, double expected_pitch_hz) const {
  CostBreakdown out;
  if (samples_.size() < 2) return out;
  const double duration = samples_.back().time_s - samples_.front().time_s;
  const double sample_rate = (samples_.size() - 1) / duration;

  std::vector<double> pitch;
  std::vector<PerLeg<bool>> contacts;
  pitch.reserve(samples_.size());
  contacts.reserve(samples_.size());
  double active[4] = {0, 0, 0, 0};
  double hip_torque = 0.0, knee_torque = 0.0;
  const std::size_t legs = samples_.front().contact.size();
  for (const auto& s : samples_) {
    pitch.push_back(s.pitch_rad);
    contacts.push_back(s.contact);
    for (std::size_t leg = 0; leg < legs; ++leg) {
      active[0] += s.activity[leg].late_touchdown;
      active[1] += s.activity[leg].early_touchdown;
      active[2] += s.activity[leg].early_toeoff;
      active[3] += s.activity[leg].late_toeoff;
      hip_torque += s.abs_hip_torque_nm[leg];
      knee_torque += s.abs_knee_torque_nm[leg];
    }
  }
  const double per_leg_samples = static_cast<double>(samples_.size()) * static_cast<double>(std::max<std::size_t>(legs, 1));
  out.feedback_fraction = {active[0] / per_leg_samples, active[1] / per_leg_samples,
                           active[2] / per_leg_samples, active[3] / per_leg_samples};
  const auto& ff = out.feedback_fraction;
  out.terms.feedback = ff.late_touchdown + ff.early_touchdown + ff.early_toeoff + ff.late_toeoff;

  out.distance_m = samples_.back().x_m - samples_.front().x_m;
  out.mean_speed_mps = out.distance_m / duration;
  out.terms.distance = 1.0 / std::max(out.distance_m, config_.min_distance_m);
  // Caps (see the header): the pitch range of a rollout that did not fall is below 2 x the fall pitch anyway.
  out.terms.pitch = std::min(pitch_range_term(pitch, sample_rate, cpg_frequency_hz), 2.0 * config_.fall_max_abs_pitch_rad);
  out.terms.contact = std::min(contact_term(contacts, sample_rate, cpg_frequency_hz), config_.contact_cap);
  out.terms.periodicity = periodicity_term(pitch, sample_rate, expected_pitch_hz);

  // Sum over legs of the per-leg mean torques = total / number of samples.
  const double torque_sum = (hip_torque + knee_torque) / samples_.size();
  out.summed_torque_nm = torque_sum;
  const double speed_floor = config_.min_distance_m / duration;
  out.normalized_torque = torque_sum / std::max(out.mean_speed_mps, speed_floor);

  const auto& w = config_.weights;
  out.cost = w.feedback * out.terms.feedback + w.distance * out.terms.distance + w.pitch * out.terms.pitch +
             w.contact * out.terms.contact + w.periodicity * out.terms.periodicity;
  return out;
}

}  // namespace cpgmatch
