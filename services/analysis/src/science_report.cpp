#include "cpgmatch/analysis/science_report.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "cpgmatch/analysis/statistics.hpp"

namespace cpgmatch::analysis {
namespace {

// Rollout k (1-based) of the study.
int rollout_number(const Trial& t) { return t.trial_id + 1; }

std::vector<const Trial*> walked_in(const StudyTrials& s, int first, int last) {
  std::vector<const Trial*> out;
  for (const auto& t : s.trials) {
    if (t.walked() && rollout_number(t) >= first && rollout_number(t) <= last) out.push_back(&t);
  }
  return out;
}

template <typename F>
std::vector<double> values(const std::vector<const Trial*>& trials, F f) {
  std::vector<double> v;
  for (const Trial* t : trials) v.push_back(f(*t));
  return v;
}

double feedback(const Trial& t) { return t.terms.feedback; }
double torque(const Trial& t) { return t.normalized_torque; }
double summed_torque(const Trial& t) { return t.summed_torque_nm; }
double speed(const Trial& t) { return t.mean_speed_mps; }

WindowStats window_stats(const StudyTrials& s, Window w, int n) {
  WindowStats ws;
  ws.window = {std::max(1, w.first), std::min(n, w.last)};
  for (const auto& t : s.trials) {
    const int k = rollout_number(t);
    if (k < ws.window.first || k > ws.window.last) continue;
    ++ws.rollouts;
    if (t.ok && t.fell) ++ws.falls;
  }
  const auto walked = walked_in(s, ws.window.first, ws.window.last);
  ws.walked = static_cast<int>(walked.size());
  ws.feedback_mean = mean(values(walked, feedback));
  ws.feedback_median = median(values(walked, feedback));
  ws.normalized_torque_median = median(values(walked, torque));
  ws.summed_torque_median_nm = median(values(walked, summed_torque));
  ws.speed_mean_mps = mean(values(walked, speed));
  return ws;
}

void correlations(const StudyTrials& s, ScienceReport& r) {
  // The log-log fit needs positive torque and speed; a rollout that walked backwards or not at all has
  // no meaningful normalised torque (eq. 1 divides by its speed) and is left out of all three.
  std::vector<double> fb, nt, st, log_nt, log_v;
  for (const auto& t : s.trials) {
    if (!t.walked() || !(t.normalized_torque > 0.0) || !(t.mean_speed_mps > 0.0) || !std::isfinite(t.terms.feedback)) {
      continue;
    }
    fb.push_back(t.terms.feedback);
    nt.push_back(t.normalized_torque);
    st.push_back(t.summed_torque_nm);
    log_nt.push_back(std::log(t.normalized_torque));
    log_v.push_back(std::log(t.mean_speed_mps));
  }
  r.correlation_samples = static_cast<int>(fb.size());
  r.rho_feedback_torque = spearman(fb, nt);
  r.rho_feedback_summed_torque = spearman(fb, st);
  r.torque_speed_exponent = fb.size() >= 2 ? least_squares(log_v, log_nt).slope : std::nan("");
  r.rho_feedback_torque_residual = spearman(fb, residuals(log_v, log_nt));
}

// The lowest-cost quarter (rounded up) of these rollouts.
std::vector<const Trial*> best_quartile(std::vector<const Trial*> rollouts) {
  std::stable_sort(rollouts.begin(), rollouts.end(), [](const Trial* a, const Trial* b) { return a->cost < b->cost; });
  rollouts.resize((rollouts.size() + 3) / 4);
  return rollouts;
}

}  // namespace

SmallTerms small_terms(const std::vector<const Trial*>& rollouts, double small_term_fraction) {
  SmallTerms out;
  int contact = 0, periodicity = 0, both = 0;
  for (const Trial* t : rollouts) {
    const double scale = small_term_fraction * (t->terms.feedback + t->terms.distance);
    const bool c = t->terms.contact < scale, p = t->terms.periodicity < scale;
    contact += c;
    periodicity += p;
    both += c && p;
  }
  out.rollouts = static_cast<int>(rollouts.size());
  const double n = out.rollouts;
  out.contact = n > 0 ? contact / n : std::nan("");
  out.periodicity = n > 0 ? periodicity / n : std::nan("");
  out.both = n > 0 ? both / n : std::nan("");
  return out;
}

ScienceReport science_report(const StudyTrials& s, const ReportOptions& o) {
  ScienceReport r;
  r.name = s.name;
  r.study_id = s.study_id;
  r.rollouts = static_cast<int>(s.trials.size());
  r.synthetic_left_out = s.synthetic_left_out;
  r.initial_points = s.initial_points;
  const int n = r.rollouts;

  std::vector<double> costs;
  double best = std::numeric_limits<double>::infinity(), worst = -best;
  const Trial* best_trial = nullptr;
  for (const auto& t : s.trials) {
    if (!t.ok) {
      ++r.failed_evaluations;
      continue;
    }
    if (t.fell) {
      ++r.falls;
      ++(rollout_number(t) <= s.initial_points ? r.falls_initial : r.falls_after);
    }
    if (!std::isfinite(t.cost)) continue;
    costs.push_back(t.cost);
    if (t.cost < best) {
      best = t.cost;
      best_trial = &t;
    }
    if (t.cost > worst) {
      worst = t.cost;
      r.worst_rollout = rollout_number(t);
    }
  }
  r.cost_mean = mean(costs);
  r.cost_sd = sample_sd(costs);
  r.cost_median = median(costs);
  r.worst_cost = costs.empty() ? std::nan("") : worst;

  for (const Window& w : o.windows) {
    if (w.first > n || w.last < w.first) continue;  // beyond this study's length
    r.windows.push_back(window_stats(s, w, n));
  }

  const auto initial = walked_in(s, 1, s.initial_points);
  r.late_first_rollout = std::max(1, n - o.last_rollouts + 1);
  const auto late = walked_in(s, r.late_first_rollout, n);
  r.feedback_initial_mean = mean(values(initial, feedback));
  r.feedback_late_mean = mean(values(late, feedback));
  r.feedback_ratio = r.feedback_late_mean / r.feedback_initial_mean;
  r.torque_initial_median = median(values(initial, torque));
  r.torque_late_median = median(values(late, torque));
  r.torque_ratio = r.torque_late_median / r.torque_initial_median;

  const auto all_walked = walked_in(s, 1, n);
  r.torque_mean = mean(values(all_walked, torque));
  r.torque_sd = sample_sd(values(all_walked, torque));
  r.torque_median = median(values(all_walked, torque));

  if (best_trial) {
    r.best_rollout = rollout_number(*best_trial);
    r.best_cost = best_trial->cost;
    r.best_terms = best_trial->terms;
    r.best_speed_mps = best_trial->mean_speed_mps;
    r.best_normalized_torque = best_trial->normalized_torque;
    r.best_fell = best_trial->fell;
    r.best_params = best_trial->params;
  } else {
    r.best_cost = r.best_speed_mps = r.best_normalized_torque = std::nan("");
  }

  correlations(s, r);

  const SmallTerms all_small = small_terms(all_walked, o.small_term_fraction);
  r.fraction_contact_small = all_small.contact;
  r.fraction_periodicity_small = all_small.periodicity;
  r.fraction_both_small = all_small.both;
  r.small_terms_best_quartile = small_terms(best_quartile(all_walked), o.small_term_fraction);

  r.measures = energy_claim(s, s.initial_points, r.late_first_rollout);
  r.knee_steady_share_median = knee_steady_share_median(s);
  r.falls_after_locations = fall_locations(s);
  r.recommendation = recommend(s);
  return r;
}

const std::map<std::string, double>& answer_params(const ScienceReport& r) {
  return r.recommendation ? r.recommendation->params : r.best_params;
}

}  // namespace cpgmatch::analysis
