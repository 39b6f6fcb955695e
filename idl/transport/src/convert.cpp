#include "cpgmatch/dds/convert.hpp"

#include <algorithm>
#include <limits>

#include <fmt/format.h>

#include "wire_numbers.hpp"

namespace cpgmatch::dds {

namespace {

// Bounded wire strings (string<N>) keep their first N characters: a long error message is cut, not refused.
template <typename Bounded>
std::string text(const Bounded& s) {
  return s.to_string();
}

template <typename Enum>
Enum checked_enum(int value, int last, const char* field) {
  if (value < 0 || value > last) throw WireError(fmt::format("{} = {} is not a valid value", field, value));
  return static_cast<Enum>(value);
}

domain::Outcome outcome_from_wire(msg::RolloutOutcome o) {
  switch (o) {
    case msg::OUTCOME_COMPLETED: return domain::Outcome::kCompleted;
    case msg::OUTCOME_FELL: return domain::Outcome::kFell;
    case msg::OUTCOME_REFUSED: return domain::Outcome::kRefused;
    case msg::OUTCOME_PLANT_FAULT: return domain::Outcome::kPlantFault;
    case msg::OUTCOME_DIVERGED: return domain::Outcome::kDiverged;
    case msg::OUTCOME_ERROR: return domain::Outcome::kError;
  }
  throw WireError(fmt::format("outcome = {} is not a RolloutOutcome", static_cast<int>(o)));
}

domain::WorkerKind kind_from_wire(msg::WorkerKind k) {
  if (k == msg::WORKER_SIM) return domain::WorkerKind::kSimulation;
  if (k == msg::WORKER_HARDWARE) return domain::WorkerKind::kHardware;
  throw WireError(fmt::format("worker kind = {} is not a WorkerKind", static_cast<int>(k)));
}

}  // namespace

namespace wire {

domain::AttemptId attempt_id(std::uint64_t store_id, std::uint32_t study_id, std::uint32_t trial_id,
                             std::uint32_t attempt) {
  for (const auto& [name, v] : {std::pair<const char*, std::uint32_t>{"study_id", study_id},
                                {"trial_id", trial_id},
                                {"attempt", attempt}}) {
    if (v > static_cast<std::uint32_t>(std::numeric_limits<int>::max())) {
      throw WireError(fmt::format("{} = {} is out of range", name, v));
    }
  }
  return {store_id, static_cast<int>(study_id), static_cast<int>(trial_id), static_cast<int>(attempt)};
}

int clamped(std::uint32_t v) { return static_cast<int>(std::min<std::uint32_t>(v, std::numeric_limits<int>::max())); }

}  // namespace wire

using wire::attempt_id;
using wire::clamped;
using wire::u32;


std::optional<domain::AttemptId> attempt_of(const msg::Candidate& c) {
  try {
    return attempt_id(c.store_id(), c.study_id(), c.trial_id(), c.attempt());
  } catch (const WireError&) {
    return std::nullopt;
  }
}

std::vector<msg::ParameterValue> to_wire(const std::map<std::string, double>& named) {
  std::vector<msg::ParameterValue> out;
  out.reserve(named.size());
  for (const auto& [name, value] : named) {
    msg::ParameterValue v;
    v.name(name);
    v.value(value);
    out.push_back(v);
  }
  return out;
}

std::map<std::string, double> from_wire(const std::vector<msg::ParameterValue>& values) {
  std::map<std::string, double> out;
  for (const auto& v : values) {
    if (!out.emplace(text(v.name()), v.value()).second) {
      throw WireError(fmt::format("parameter '{}' given twice", text(v.name())));
    }
  }
  return out;
}

namespace {

using WireName = eprosima::fastrtps::fixed_string<32>;

std::vector<WireName> names_to_wire(const std::vector<std::string>& names, std::size_t most, const char* what) {
  if (names.size() > most) throw WireError(fmt::format("{} {}: a sample carries at most {}", names.size(), what, most));
  return {names.begin(), names.end()};
}

std::vector<std::string> names_from_wire(const std::vector<WireName>& names) {
  std::vector<std::string> out;
  for (const auto& n : names) out.push_back(text(n));
  return out;
}

}  // namespace

msg::RolloutOutcome to_wire(domain::Outcome o) {
  switch (o) {
    case domain::Outcome::kCompleted: return msg::OUTCOME_COMPLETED;
    case domain::Outcome::kFell: return msg::OUTCOME_FELL;
    case domain::Outcome::kRefused: return msg::OUTCOME_REFUSED;
    case domain::Outcome::kPlantFault: return msg::OUTCOME_PLANT_FAULT;
    case domain::Outcome::kDiverged: return msg::OUTCOME_DIVERGED;
    case domain::Outcome::kError: return msg::OUTCOME_ERROR;
  }
  return msg::OUTCOME_ERROR;
}

msg::WorkerKind to_wire(domain::WorkerKind k) {
  return k == domain::WorkerKind::kHardware ? msg::WORKER_HARDWARE : msg::WORKER_SIM;
}

msg::StudyStatus to_wire(domain::StudyStatus s) {
  switch (s) {
    case domain::StudyStatus::kRunning: return msg::STUDY_RUNNING;
    case domain::StudyStatus::kPaused: return msg::STUDY_PAUSED;
    case domain::StudyStatus::kDone: return msg::STUDY_DONE;
    case domain::StudyStatus::kFailed: return msg::STUDY_FAILED;
    case domain::StudyStatus::kStopped: return msg::STUDY_STOPPED;
  }
  return msg::STUDY_FAILED;
}

msg::CommandKind to_wire(domain::CommandKind k) {
  switch (k) {
    case domain::CommandKind::kSubmit: return msg::COMMAND_SUBMIT;
    case domain::CommandKind::kPause: return msg::COMMAND_PAUSE;
    case domain::CommandKind::kResume: return msg::COMMAND_RESUME;
    case domain::CommandKind::kStop: return msg::COMMAND_STOP;
    case domain::CommandKind::kExtend: return msg::COMMAND_EXTEND;
    case domain::CommandKind::kEnqueue: return msg::COMMAND_ENQUEUE;
  }
  return msg::COMMAND_STOP;
}

// ---- reports -------------------------------------------------------------------------------------

msg::RolloutReport to_wire(const domain::RolloutReport& r) {
  msg::RolloutReport w;
  w.store_id(r.id.store_id);
  w.study_id(u32(r.id.study_id));
  w.trial_id(u32(r.id.trial_id));
  w.attempt(u32(r.id.attempt));
  w.worker_id(r.worker_id);
  w.worker_kind(to_wire(r.worker_kind));
  w.ok(r.ok());
  w.outcome(to_wire(r.outcome));
  w.error(r.error.substr(0, 255));
  const domain::RolloutSummary& s = r.summary;
  w.cost(s.cost);
  w.j_feedback(s.terms.feedback);
  w.j_distance(s.terms.distance);
  w.j_pitch(s.terms.pitch);
  w.j_contact(s.terms.contact);
  w.j_periodicity(s.terms.periodicity);
  w.normalized_torque(s.normalized_torque);
  w.summed_torque_nm(s.summed_torque_nm);
  w.late_touchdown_fraction(s.feedback.late_touchdown);
  w.early_touchdown_fraction(s.feedback.early_touchdown);
  w.early_toeoff_fraction(s.feedback.early_toeoff);
  w.late_toeoff_fraction(s.feedback.late_toeoff);
  w.fell(r.fell());
  w.fall_time_s(s.fall_time_s);
  w.distance_m(s.distance_m);
  w.mean_speed_mps(s.mean_speed_mps);
  w.wall_time_s(r.wall_time_s);
  w.loop_jitter_p50_us(r.loop.jitter_p50_us);
  w.loop_jitter_p99_us(r.loop.jitter_p99_us);
  w.loop_jitter_max_us(r.loop.jitter_max_us);
  w.loop_overruns(u32(r.loop.overruns));
  const EnergyMeasures& e = s.energy;
  w.positive_work_j(e.positive_work_j);
  w.joule_loss_j(e.joule_loss_j);
  w.electrical_j(e.electrical_j);
  w.hip_positive_work_j_per_m(e.hip_positive_work_j_per_m);
  w.knee_positive_work_j_per_m(e.knee_positive_work_j_per_m);
  w.positive_work_j_per_m(e.positive_work_j_per_m);
  w.mechanical_cost_of_transport(e.mechanical_cost_of_transport);
  w.electrical_cost_of_transport(e.electrical_cost_of_transport);
  w.signed_torque_per_speed(e.signed_torque_per_speed);
  // Per leg for any count (leg_energy), and in the four-leg arrays too for readers built before it.
  if (e.hip.size() != e.knee.size() || e.hip.size() > kMaxLegs) {
    throw WireError(fmt::format("energy of {} hips and {} knees: a report carries 1 to {} legs", e.hip.size(), e.knee.size(), kMaxLegs));
  }
  const auto joint_to_wire = [](const JointEnergy& j) {
    msg::JointEnergy out;
    out.positive_work_j(j.positive_work_j);
    out.joule_loss_j(j.joule_loss_j);
    out.electrical_j(j.electrical_j);
    out.signed_mean_torque_nm(j.signed_mean_torque_nm);
    return out;
  };
  for (std::size_t leg = 0; leg < e.hip.size(); ++leg) {
    msg::LegEnergy l;
    l.hip(joint_to_wire(e.hip[leg]));
    l.knee(joint_to_wire(e.knee[leg]));
    w.leg_energy().push_back(l);
  }
  const bool four = e.hip.size() == w.hip_positive_work_j().size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t leg = 0; leg < w.hip_positive_work_j().size(); ++leg) {
    w.hip_positive_work_j()[leg] = four ? e.hip[leg].positive_work_j : nan;
    w.hip_joule_loss_j()[leg] = four ? e.hip[leg].joule_loss_j : nan;
    w.hip_electrical_j()[leg] = four ? e.hip[leg].electrical_j : nan;
    w.hip_signed_mean_torque_nm()[leg] = four ? e.hip[leg].signed_mean_torque_nm : nan;
    w.knee_positive_work_j()[leg] = four ? e.knee[leg].positive_work_j : nan;
    w.knee_joule_loss_j()[leg] = four ? e.knee[leg].joule_loss_j : nan;
    w.knee_electrical_j()[leg] = four ? e.knee[leg].electrical_j : nan;
    w.knee_signed_mean_torque_nm()[leg] = four ? e.knee[leg].signed_mean_torque_nm : nan;
  }
  w.synthetic(r.synthetic);
  return w;
}

domain::RolloutReport from_wire(const msg::RolloutReport& w) {
  domain::RolloutReport r;
  r.id = attempt_id(w.store_id(), w.study_id(), w.trial_id(), w.attempt());
  r.worker_id = text(w.worker_id());
  r.worker_kind = kind_from_wire(w.worker_kind());
  r.outcome = outcome_from_wire(w.outcome());
  // The wire carries ok and fell beside the outcome (for readers that predate outcomes); they must agree.
  if (w.ok() != r.ok()) throw WireError(fmt::format("ok = {} contradicts outcome {}", w.ok(), to_string(r.outcome)));
  if (w.ok() && w.fell() != r.fell()) {
    throw WireError(fmt::format("fell = {} contradicts outcome {}", w.fell(), to_string(r.outcome)));
  }
  r.error = text(w.error());
  domain::RolloutSummary& s = r.summary;
  s.cost = w.cost();
  s.terms.feedback = w.j_feedback();
  s.terms.distance = w.j_distance();
  s.terms.pitch = w.j_pitch();
  s.terms.contact = w.j_contact();
  s.terms.periodicity = w.j_periodicity();
  s.normalized_torque = w.normalized_torque();
  s.summed_torque_nm = w.summed_torque_nm();
  s.feedback.late_touchdown = w.late_touchdown_fraction();
  s.feedback.early_touchdown = w.early_touchdown_fraction();
  s.feedback.early_toeoff = w.early_toeoff_fraction();
  s.feedback.late_toeoff = w.late_toeoff_fraction();
  s.fall_time_s = w.fall_time_s();
  s.distance_m = w.distance_m();
  s.mean_speed_mps = w.mean_speed_mps();
  r.wall_time_s = w.wall_time_s();
  r.loop.jitter_p50_us = w.loop_jitter_p50_us();
  r.loop.jitter_p99_us = w.loop_jitter_p99_us();
  r.loop.jitter_max_us = w.loop_jitter_max_us();
  r.loop.overruns = clamped(w.loop_overruns());
  r.synthetic = w.synthetic();
  EnergyMeasures& e = s.energy;
  e.positive_work_j = w.positive_work_j();
  e.joule_loss_j = w.joule_loss_j();
  e.electrical_j = w.electrical_j();
  e.hip_positive_work_j_per_m = w.hip_positive_work_j_per_m();
  e.knee_positive_work_j_per_m = w.knee_positive_work_j_per_m();
  e.positive_work_j_per_m = w.positive_work_j_per_m();
  e.mechanical_cost_of_transport = w.mechanical_cost_of_transport();
  e.electrical_cost_of_transport = w.electrical_cost_of_transport();
  e.signed_torque_per_speed = w.signed_torque_per_speed();
  if (!w.leg_energy().empty()) {
    const auto joint_from_wire = [](const msg::JointEnergy& j) {
      return JointEnergy{j.positive_work_j(), j.joule_loss_j(), j.electrical_j(), j.signed_mean_torque_nm()};
    };
    e.hip = PerLeg<JointEnergy>(w.leg_energy().size());
    e.knee = PerLeg<JointEnergy>(w.leg_energy().size());
    for (std::size_t leg = 0; leg < w.leg_energy().size(); ++leg) {
      e.hip[leg] = joint_from_wire(w.leg_energy()[leg].hip());
      e.knee[leg] = joint_from_wire(w.leg_energy()[leg].knee());
    }
  } else {
    // A writer built before leg_energy: the four-leg arrays.
    e.hip = PerLeg<JointEnergy>(w.hip_positive_work_j().size());
    e.knee = PerLeg<JointEnergy>(w.knee_positive_work_j().size());
    for (std::size_t leg = 0; leg < e.hip.size(); ++leg) {
      e.hip[leg] = {w.hip_positive_work_j()[leg], w.hip_joule_loss_j()[leg], w.hip_electrical_j()[leg],
                    w.hip_signed_mean_torque_nm()[leg]};
      e.knee[leg] = {w.knee_positive_work_j()[leg], w.knee_joule_loss_j()[leg], w.knee_electrical_j()[leg],
                     w.knee_signed_mean_torque_nm()[leg]};
    }
  }
  return r;
}

// ---- candidates ----------------------------------------------------------------------------------

msg::Candidate to_wire(const domain::Candidate& c) {
  msg::Candidate w;
  w.store_id(c.id.store_id);
  w.study_id(u32(c.id.study_id));
  w.trial_id(u32(c.id.trial_id));
  w.attempt(u32(c.id.attempt));
  w.worker_id(c.worker_id);
  w.lease_s(c.lease_s);
  w.spec_key(c.spec_key);
  msg::RolloutSpec rollout;
  rollout.entrain_s(c.rollout.entrain_s);
  rollout.eval_s(c.rollout.eval_s);
  rollout.terrain(c.rollout.terrain);
  rollout.seed(c.rollout.seed);
  w.rollout(rollout);
  w.parameters(to_wire(c.parameters));
  return w;
}

domain::Candidate from_wire(const msg::Candidate& w) {
  domain::Candidate c;
  c.id = attempt_id(w.store_id(), w.study_id(), w.trial_id(), w.attempt());
  c.worker_id = text(w.worker_id());
  c.lease_s = w.lease_s();
  c.spec_key = w.spec_key();
  c.rollout.entrain_s = w.rollout().entrain_s();
  c.rollout.eval_s = w.rollout().eval_s();
  c.rollout.terrain = text(w.rollout().terrain());
  c.rollout.seed = w.rollout().seed();
  c.parameters = from_wire(w.parameters());
  return c;
}

// ---- workers -------------------------------------------------------------------------------------

msg::WorkerAnnouncement to_wire(const domain::WorkerAnnouncement& a) {
  msg::WorkerAnnouncement w;
  w.worker_key(a.worker_key);
  w.worker_id(a.worker_id);
  w.kind(to_wire(a.kind));
  w.host(a.host);
  w.pid(a.pid);
  w.slots(u32(a.slots));
  w.busy(u32(a.busy));
  w.completed(a.completed);
  w.accepting(a.accepting);
  w.heartbeat_period_s(a.heartbeat_period_s);
  w.status(a.status.substr(0, 255));
  w.objective_version(u32(a.objective_version));
  return w;
}

domain::WorkerAnnouncement from_wire(const msg::WorkerAnnouncement& w) {
  domain::WorkerAnnouncement a;
  a.worker_key = w.worker_key();
  a.worker_id = text(w.worker_id());
  a.kind = kind_from_wire(w.kind());
  a.host = text(w.host());
  a.pid = w.pid();
  // Slot counts beyond int are no count a worker has (the coordinator refuses more than 4096 anyway).
  a.slots = clamped(w.slots());
  a.busy = clamped(w.busy());
  a.completed = w.completed();
  a.accepting = w.accepting();
  a.heartbeat_period_s = w.heartbeat_period_s();
  a.status = text(w.status());
  a.objective_version = clamped(w.objective_version());
  return a;
}

// ---- commands ------------------------------------------------------------------------------------

msg::StudyCommand to_wire(const domain::StudyCommand& c) {
  msg::StudyCommand w;
  w.correlation_id(c.correlation_id);
  w.client_id(c.client_id);
  w.kind(to_wire(c.kind));
  w.study_id(u32(c.study_id));
  w.study_yaml(c.study_yaml);
  w.source_name(c.source_name.substr(0, 255));
  w.added_trials(c.added_trials);
  std::vector<msg::EnqueuedGait> gaits;
  for (const auto& g : c.enqueue) {
    msg::EnqueuedGait e;
    e.source(g.source.substr(0, 255));
    e.parameters(to_wire(g.parameters));
    gaits.push_back(std::move(e));
  }
  w.enqueue(std::move(gaits));
  return w;
}

domain::StudyCommand from_wire(const msg::StudyCommand& w) {
  domain::StudyCommand c;
  c.correlation_id = w.correlation_id();
  c.client_id = text(w.client_id());
  c.kind = checked_enum<domain::CommandKind>(static_cast<int>(w.kind()), msg::COMMAND_ENQUEUE, "kind");
  if (w.study_id() > static_cast<std::uint32_t>(std::numeric_limits<int>::max())) {
    throw WireError(fmt::format("study_id = {} is out of range", w.study_id()));
  }
  c.study_id = static_cast<int>(w.study_id());
  c.study_yaml = w.study_yaml();
  c.source_name = text(w.source_name());
  c.added_trials = w.added_trials();
  for (const auto& e : w.enqueue()) c.enqueue.push_back(domain::EnqueuedGait{text(e.source()), from_wire(e.parameters())});
  return c;
}

msg::CommandReply to_wire(const domain::CommandReply& r) {
  msg::CommandReply w;
  w.correlation_id(r.correlation_id);
  w.client_id(r.client_id);
  w.ok(r.ok);
  w.study_id(u32(r.study_id));
  w.message(r.message.substr(0, 1023));
  return w;
}

domain::CommandReply from_wire(const msg::CommandReply& w) {
  domain::CommandReply r;
  r.correlation_id = w.correlation_id();
  r.client_id = text(w.client_id());
  r.ok = w.ok();
  r.study_id = clamped(w.study_id());
  r.message = text(w.message());
  return r;
}

// ---- study state, trials, specs ------------------------------------------------------------------

msg::StudyState to_wire(const domain::StudyState& s) {
  msg::StudyState w;
  w.study_id(u32(s.study_id));
  w.name(s.name);
  w.state(to_wire(s.status));
  w.budget(u32(s.budget));
  w.completed(u32(s.completed));
  w.in_flight(u32(s.in_flight));
  w.failed(u32(s.failed));
  w.falls(u32(s.falls));
  w.reissued(u32(s.reissued));
  w.workers(u32(s.workers));
  w.best_cost(s.best_cost);
  w.best_trial(u32(s.best_trial));
  w.best_params(to_wire(s.best_params));
  w.best_normalized_torque(s.best_normalized_torque);
  w.best_speed_mps(s.best_speed_mps);
  w.elapsed_s(s.elapsed_s);
  w.rollouts_per_s(s.rollouts_per_s);
  w.message(s.message.substr(0, 255));
  w.has_recommendation(s.has_recommendation);
  if (s.has_recommendation) {
    w.recommended_trial(u32(s.recommendation.trial));
    w.recommended_predicted_cost(s.recommendation.predicted_cost);
    w.recommended_params(to_wire(s.recommendation.params));
  }
  w.leg_names(names_to_wire(s.leg_names, kMaxLegs, "legs"));
  if (s.search_space.size() > 32) throw WireError(fmt::format("{} searched parameters: a state carries at most 32", s.search_space.size()));
  for (const domain::SearchAxis& a : s.search_space) {
    msg::SearchDimension d;
    d.name(a.name);
    d.low(a.low);
    d.high(a.high);
    d.log_scale(a.log_scale);
    d.unit(a.unit);
    w.search_space().push_back(d);
  }
  return w;
}

domain::StudyState from_wire(const msg::StudyState& w) {
  domain::StudyState s;
  s.study_id = clamped(w.study_id());
  s.name = text(w.name());
  s.status = checked_enum<domain::StudyStatus>(static_cast<int>(w.state()), msg::STUDY_STOPPED, "state");
  s.budget = clamped(w.budget());
  s.completed = clamped(w.completed());
  s.in_flight = clamped(w.in_flight());
  s.failed = clamped(w.failed());
  s.falls = clamped(w.falls());
  s.reissued = clamped(w.reissued());
  s.workers = clamped(w.workers());
  s.best_cost = w.best_cost();
  s.best_trial = clamped(w.best_trial());
  s.best_params = from_wire(w.best_params());
  s.best_normalized_torque = w.best_normalized_torque();
  s.best_speed_mps = w.best_speed_mps();
  s.elapsed_s = w.elapsed_s();
  s.rollouts_per_s = w.rollouts_per_s();
  s.message = text(w.message());
  s.has_recommendation = w.has_recommendation();
  if (s.has_recommendation) {
    s.recommendation.trial = clamped(w.recommended_trial());
    s.recommendation.predicted_cost = w.recommended_predicted_cost();
    s.recommendation.params = from_wire(w.recommended_params());
  }
  s.leg_names = names_from_wire(w.leg_names());
  for (const msg::SearchDimension& d : w.search_space()) {
    s.search_space.push_back({text(d.name()), d.low(), d.high(), d.log_scale(), text(d.unit())});
  }
  return s;
}

msg::TrialRecord to_wire(const domain::TrialRecord& t) {
  msg::TrialRecord w;
  w.study_id(u32(t.study_id));
  w.trial_id(u32(t.trial_id));
  w.initial(t.initial);
  w.parameters(to_wire(t.parameters));
  w.report(to_wire(t.report));
  w.enqueued(t.enqueued);
  w.leg_names(names_to_wire(t.leg_names, kMaxLegs, "legs"));
  return w;
}

domain::TrialRecord from_wire(const msg::TrialRecord& w) {
  domain::TrialRecord t;
  t.study_id = clamped(w.study_id());
  t.trial_id = clamped(w.trial_id());
  t.initial = w.initial();
  t.parameters = from_wire(w.parameters());
  t.report = from_wire(w.report());
  t.enqueued = w.enqueued();
  t.leg_names = names_from_wire(w.leg_names());
  return t;
}

msg::EmergencyStop to_wire(const domain::EmergencyStop& s) {
  msg::EmergencyStop w;
  w.stop_id(s.stop_id);
  w.target(s.target);
  w.release(s.release);
  w.reason(s.reason.substr(0, 127));
  w.sender(s.sender);
  return w;
}

domain::EmergencyStop from_wire(const msg::EmergencyStop& w) {
  return domain::EmergencyStop{w.stop_id(), text(w.target()), w.release(), text(w.reason()), text(w.sender())};
}

msg::StudySpecSample to_wire(const domain::SpecPublication& s) {
  msg::StudySpecSample w;
  w.spec_key(s.key);
  w.objective_version(u32(s.objective_version));
  w.sha256(s.sha256);
  w.spec_json(s.json);
  return w;
}

domain::SpecPublication from_wire(const msg::StudySpecSample& w) {
  domain::SpecPublication s;
  s.key = w.spec_key();
  s.objective_version = clamped(w.objective_version());
  s.sha256 = text(w.sha256());
  s.json = text(w.spec_json());
  return s;
}

}  // namespace cpgmatch::dds
