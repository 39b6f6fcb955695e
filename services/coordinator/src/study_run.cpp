#include "cpgmatch/service/study_run.hpp"

#include <algorithm>

#include "cpgmatch/domain/worker_identity.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/seeds.hpp"

namespace cpgmatch::service {

namespace {

// The recommended observation (either optimizer's Recommendation: its index and predicted cost) as a snapshot.
template <typename Recommendation>
ModelSnapshot snapshot(const std::optional<Recommendation>& rec, const std::vector<bo::Observation>& observations,
                       const bo::SearchSpace& space, const std::vector<int>& trials) {
  ModelSnapshot m;
  if (rec) {
    m.has_recommendation = true;
    m.recommended_trial = trials.at(rec->observation);
    m.recommended_predicted_cost = rec->predicted;
    m.recommended_x = observations[rec->observation].x;
    m.recommended_params = space.to_named(m.recommended_x);
  }
  return m;
}

}  // namespace

ModelSnapshot ModelSnapshot::of(const bo::BayesianOptimizer& optimizer, const std::vector<int>& told_trials) {
  return snapshot(optimizer.recommended(), optimizer.observations(), optimizer.space(), told_trials);
}

ModelSnapshot ModelSnapshot::of(bo::HardwareOptimizer& optimizer, const std::vector<int>& told_hardware_trials) {
  auto rec = optimizer.recommended();  // first: it fits the model when its observations changed
  return snapshot(rec, optimizer.hardware_observations(), optimizer.space(), told_hardware_trials);
}

bo::HardwareOptimizerOptions hardware_model_options(const study::StudyConfig& config) {
  bo::HardwareOptimizerOptions o;
  o.strategy = config.hardware.strategy == study::HardwareStrategy::kTransfer ? bo::HardwareStrategy::kTransfer
                                                                             : bo::HardwareStrategy::kMultiFidelity;
  o.max_fall_probability = config.hardware.max_fall_probability;
  o.safe_margin = config.hardware.safe_margin;
  o.safe_beta = config.hardware.safe_beta;
  // The same units as the study's optimizer (log by default: the fall cliff, docs/optimizer.md).
  o.cost_transform = config.optimizer.cost_transform;
  // Always on, whatever the study's fall_model: on hardware a fall is a robot on the floor.
  o.fall_model = true;
  o.seed = config.optimizer.seed;
  return o;
}

int StudyRun::exploring_in_flight() const {
  return static_cast<int>(
      std::count_if(in_flight.begin(), in_flight.end(), [](const auto& kv) { return !kv.second.hardware_only(); }));
}

int StudyRun::hardware_in_flight() const {
  return static_cast<int>(
      std::count_if(in_flight.begin(), in_flight.end(), [](const auto& kv) { return kv.second.hardware; }));
}

int StudyRun::hardware_to_propose() const {
  return models_hardware() ? std::max(0, config.hardware.budget - hardware_done - hardware_in_flight()) : 0;
}

bool StudyRun::complete() const {
  if (completed < config.budget) return false;
  const auto& v = config.validation;
  if (v.enabled) return validation_started && validated >= v.hardware_sets;
  if (models_hardware()) {
    return hardware_done >= config.hardware.budget && in_flight.empty() && untold.empty() &&
           hardware_untold_sim.empty() && hardware_untold.empty() && !model_busy;
  }
  return true;
}

bool StudyRun::count_outcome(const domain::RolloutReport& r) {
  dirty = true;
  if (!r.ok()) {
    ++failed;
    ++consecutive_failures;
    return false;
  }
  consecutive_failures = 0;
  if (r.fell()) ++falls;
  return true;
}

void StudyRun::account_report(int trial_id, const Eigen::VectorXd& x, const domain::RolloutReport& r) {
  ++completed;
  if (!count_outcome(r)) return;
  if (!(r.summary.cost >= best_cost)) {  // also true while best_cost is NaN
    best_cost = r.summary.cost;
    best_trial = trial_id;
    best_params = config.space.to_named(x);
    best_x = x;
    best_normalized_torque = r.summary.normalized_torque;
    best_speed_mps = r.summary.mean_speed_mps;
  }
}

void StudyRun::account_validation(int trial_id, const domain::RolloutReport& r) {
  ++validated;
  validation_trials.push_back(trial_id);
  count_outcome(r);
}

void StudyRun::account_hardware(int trial_id, const Eigen::VectorXd& x, const domain::RolloutReport& r) {
  ++hardware_done;
  hardware_trials.push_back(trial_id);
  count_outcome(r);
  hardware_untold.emplace_back(trial_id, observation(x, r));
}

bo::Observation StudyRun::observation(const Eigen::VectorXd& x, const domain::RolloutReport& r) {
  return bo::Observation{x, r.ok() ? r.summary.cost : 0.0, !r.ok(), r.fell(),
                         !r.ok() && domain::reissued_not_spent(r.outcome)};
}

bool StudyRun::is_study_robot(const PoolWorker& worker) const {
  // The same rule as a worker id and its certificate: the robot's name, or the name and a suffix.
  return !worker.hardware || config.robot.empty() || domain::worker_id_belongs_to(worker.id, config.robot);
}

bool StudyRun::may_serve(const PoolWorker& worker, double now_s) const {
  if (!is_study_robot(worker)) return false;
  const auto r = refused_by.find(worker.id);
  return r == refused_by.end() || now_s >= r->second.until_s;
}

domain::Candidate StudyRun::candidate(std::uint64_t store_id, int trial_id) const {
  const InFlight& f = in_flight.at(trial_id);
  domain::Candidate c;
  c.id = domain::AttemptId{store_id, id, trial_id, f.attempt};
  c.worker_id = f.worker_id;
  c.lease_s = config.effective_lease_s();
  c.spec_key = spec->key();
  c.rollout.entrain_s = config.entrain_s;
  c.rollout.eval_s = config.eval_s;
  c.rollout.terrain = config.terrain;
  // Each trial gets its own rollout seed (sensor noise, rough ground): the optimizer then sees the
  // rollout-to-rollout spread it must be robust to, instead of one frozen noise realisation that a lucky
  // point can exploit. Still a pure function of (study seed, trial id): same seed, same study.
  c.rollout.seed = derived_seed(config.optimizer.seed, static_cast<std::uint64_t>(trial_id));
  c.parameters = to_map(spec->base_parameters());
  for (const auto& [parameter, value] : config.space.to_named(f.x)) c.parameters[parameter] = value;
  return c;
}

domain::TrialRecord StudyRun::trial_record(int trial_id, const Eigen::VectorXd& x,
                                           const domain::RolloutReport& r) const {
  domain::TrialRecord t;
  t.study_id = id;
  t.trial_id = trial_id;
  t.enqueued = enqueued_trials.count(trial_id) > 0;
  t.initial = !t.enqueued && trial_id < config.optimizer.initial_points;
  t.parameters = config.space.to_named(x);
  t.report = r;
  t.report.id.study_id = id;
  t.report.id.trial_id = trial_id;
  if (spec) t.leg_names = spec->rollout_settings().controller.legs.names;
  return t;
}

domain::SpecPublication StudyRun::spec_publication() const {
  return domain::SpecPublication{spec->key(), static_cast<int>(spec->objective_version()), spec->sha256(),
                                 spec->canonical_json()};
}

domain::StudyState StudyRun::state_sample(int workers, double wall_now_s, double now_s) const {
  domain::StudyState st;
  st.study_id = id;
  st.name = name;
  st.status = state;
  // Both sources count: budget = exploration budget + validation sets or hardware rollouts, completed =
  // reports of either.
  const int sets = config.validation.enabled ? config.validation.hardware_sets : 0;
  const int hardware_rollouts = models_hardware() ? config.hardware.budget : 0;
  st.budget = config.budget + sets + hardware_rollouts;
  st.completed = completed + validated + hardware_done;
  st.in_flight = static_cast<int>(in_flight.size());
  st.failed = failed;
  st.falls = falls;
  st.reissued = reissued;
  st.workers = workers;
  st.best_cost = best_cost;
  st.best_trial = best_trial;
  st.best_params = best_params;
  st.best_normalized_torque = best_normalized_torque;
  st.best_speed_mps = best_speed_mps;
  // Wall time, as created_at_s is (it survives restarts): after the clock is stepped back past a study's
  // creation, 0 rather than a negative age.
  st.elapsed_s = std::max(0.0, wall_now_s - created_at_s);
  const double session = now_s - session_start_s;
  st.rollouts_per_s = session > 0.0 ? (completed - completed_at_session_start) / session : 0.0;
  st.message = message;
  // With a hardware model the answer is the hardware posterior's best hardware trial (none before the first
  // hardware result): what the robot should run, not what the simulation liked.
  // The robot's legs and the search space, so that a viewer names per-leg and per-parameter values as the
  // study does (a hexapod's L1 .. R3, its own parameters and units), never by Morti's.
  if (spec) st.leg_names = spec->rollout_settings().controller.legs.names;
  for (const bo::Dimension& d : config.space.dimensions()) {
    st.search_space.push_back({d.name, d.low, d.high, d.log_scale, d.unit});
  }
  const ModelSnapshot& answer = models_hardware() ? hardware_model : model;
  if (answer.has_recommendation) {
    st.has_recommendation = true;
    st.recommendation =
        domain::Recommendation{answer.recommended_trial, answer.recommended_predicted_cost, answer.recommended_params};
  }
  return st;
}

}  // namespace cpgmatch::service
