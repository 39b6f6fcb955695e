#include "cpgmatch/analysis/energy_claim.hpp"

#include <cmath>

#include <fmt/format.h>

#include "cpgmatch/analysis/statistics.hpp"

namespace cpgmatch::analysis {
namespace {

int rollout_number(const Trial& t) { return t.trial_id + 1; }

std::vector<double> medianed(const StudyTrials& s, const EnergyMeasureInfo& m, int first, int last) {
  std::vector<double> v;
  for (const auto& t : s.trials) {
    const int k = rollout_number(t);
    if (t.walked() && k >= first && k <= last && std::isfinite(m.of(t))) v.push_back(m.of(t));
  }
  return v;
}

}  // namespace

const std::vector<EnergyMeasureInfo>& energy_measures() {
  static const std::vector<EnergyMeasureInfo> list = {
      {"normalized_torque", "eq. 1, sum of mean |torque| / speed, N m/(m/s)", [](const Trial& t) { return t.normalized_torque; }},
      {"signed_torque_per_speed", "sum of |signed mean torque| / speed, N m/(m/s)",
       [](const Trial& t) { return t.energy.signed_torque_per_speed; }},
      {"positive_work_per_m", "positive mechanical work, J/m", [](const Trial& t) { return t.energy.positive_work_j_per_m; }},
      {"electrical_cost_of_transport", "electrical cost of transport (DC-motor model)",
       [](const Trial& t) { return t.energy.electrical_cost_of_transport; }},
  };
  return list;
}

std::vector<MeasureStats> energy_claim(const StudyTrials& s, int initial_last, int late_first) {
  std::vector<MeasureStats> out;
  const int n = static_cast<int>(s.trials.size());
  for (const auto& m : energy_measures()) {
    MeasureStats st;
    st.key = m.key;
    st.initial_median = median(medianed(s, m, 1, initial_last));
    st.late_median = median(medianed(s, m, late_first, n));
    st.ratio = st.late_median / st.initial_median;
    // The log fit needs positive values; a rollout that walked backwards has no meaningful per-speed measure.
    std::vector<double> fb, value, log_value, log_speed;
    for (const auto& t : s.trials) {
      const double v = m.of(t);
      if (!t.walked() || !(v > 0.0) || !std::isfinite(v) || !(t.mean_speed_mps > 0.0) || !std::isfinite(t.terms.feedback)) {
        continue;
      }
      fb.push_back(t.terms.feedback);
      value.push_back(v);
      log_value.push_back(std::log(v));
      log_speed.push_back(std::log(t.mean_speed_mps));
    }
    st.samples = static_cast<int>(fb.size());
    st.rho_feedback = spearman(fb, value);
    st.speed_exponent = fb.size() >= 2 ? least_squares(log_speed, log_value).slope : std::nan("");
    st.rho_feedback_residual = spearman(fb, residuals(log_speed, log_value));
    st.rho_feedback_partial = partial_spearman(fb, value, log_speed);
    out.push_back(st);
  }
  return out;
}

double knee_steady_share_median(const StudyTrials& s) {
  std::vector<double> shares;
  for (const auto& t : s.trials) {
    if (!t.walked() || !(t.summed_torque_nm > 0.0) || t.energy.knee.empty()) continue;  // no per-leg energy: unknown
    double steady = 0.0;
    for (const auto& knee : t.energy.knee) steady += std::abs(knee.signed_mean_torque_nm);
    if (std::isfinite(steady)) shares.push_back(steady / t.summed_torque_nm);
  }
  return median(shares);
}

std::string eq1_sentence(double share) {
  if (!std::isfinite(share)) {
    return "Eq. 1 (sum of mean |torque| / speed) is printed as the paper defines it; this store has no energy data "
           "to say what dominates it.";
  }
  return fmt::format(
      "Eq. 1 (sum of mean |torque| / speed) is printed as the paper defines it; {:.0f}% of its numerator (median) is "
      "the knees' steady torque of carrying the body, which does no work, and it falls as 1/speed like J_distance: "
      "the energy measures in the table (signed torque, positive work, cost of transport) separate what a gait spends.",
      100.0 * share);
}

}  // namespace cpgmatch::analysis
