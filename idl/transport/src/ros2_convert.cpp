#include "cpgmatch/dds/ros2_convert.hpp"

#include <cmath>
#include <stdexcept>
#include <vector>

#include "wire_numbers.hpp"

namespace cpgmatch::dds {

namespace {

using wire::u32;

// Named parameters as the .msg files carry them: two parallel arrays, names and values.
template <class Msg>
void set_parameters(const std::map<std::string, double>& named, Msg& out,
                    void (Msg::*names)(const std::vector<eprosima::fastrtps::fixed_string<32>>&),
                    void (Msg::*values)(const std::vector<double>&)) {
  std::vector<eprosima::fastrtps::fixed_string<32>> n;
  std::vector<double> v;
  for (const auto& [name, value] : named) {
    n.emplace_back(name);
    v.push_back(value);
  }
  (out.*names)(n);
  (out.*values)(v);
}

using RosName = eprosima::fastrtps::fixed_string<32>;

std::vector<RosName> ros_names(const std::vector<std::string>& names) { return {names.begin(), names.end()}; }

// One value of every leg's joint energy (the robot's leg order).
std::vector<double> per_leg(const PerLeg<JointEnergy>& joints, double JointEnergy::*value) {
  std::vector<double> out;
  for (const JointEnergy& j : joints) out.push_back(j.*value);
  return out;
}

std::uint8_t ros_kind(domain::WorkerKind kind) {
  // TrialRecord's WORKER_* and Worker's KIND_* have the same values (checked in the tests).
  return kind == domain::WorkerKind::kHardware ? ros::Worker_Constants::KIND_HARDWARE_
                                               : ros::Worker_Constants::KIND_SIMULATION_;
}

}  // namespace

std::uint8_t ros_status(domain::StudyStatus status) {
  namespace c = ros::StudyState_Constants;
  switch (status) {
    case domain::StudyStatus::kRunning: return c::STATUS_RUNNING_;
    case domain::StudyStatus::kPaused: return c::STATUS_PAUSED_;
    case domain::StudyStatus::kDone: return c::STATUS_DONE_;
    case domain::StudyStatus::kFailed: return c::STATUS_FAILED_;
    case domain::StudyStatus::kStopped: return c::STATUS_STOPPED_;
  }
  throw std::logic_error("unknown study status");
}

std::uint8_t ros_outcome(domain::Outcome outcome) {
  namespace c = ros::TrialRecord_Constants;
  switch (outcome) {
    case domain::Outcome::kCompleted: return c::OUTCOME_COMPLETED_;
    case domain::Outcome::kFell: return c::OUTCOME_FELL_;
    case domain::Outcome::kRefused: return c::OUTCOME_REFUSED_;
    case domain::Outcome::kPlantFault: return c::OUTCOME_PLANT_FAULT_;
    case domain::Outcome::kDiverged: return c::OUTCOME_DIVERGED_;
    case domain::Outcome::kError: return c::OUTCOME_ERROR_;
  }
  throw std::logic_error("unknown outcome");
}

ros::StudyState_ to_ros(const domain::StudyState& s) {
  ros::StudyState_ out;
  out.study_id_(u32(s.study_id));
  out.name_(s.name);
  out.status_(ros_status(s.status));
  out.budget_(u32(s.budget));
  out.completed_(u32(s.completed));
  out.in_flight_(u32(s.in_flight));
  out.failed_(u32(s.failed));
  out.falls_(u32(s.falls));
  out.reissued_(u32(s.reissued));
  out.workers_(u32(s.workers));
  out.best_cost_(s.best_cost);
  out.best_trial_(u32(s.best_trial));
  set_parameters(s.best_params, out, &ros::StudyState_::best_param_names_, &ros::StudyState_::best_param_values_);
  out.best_normalized_torque_(s.best_normalized_torque);
  out.best_speed_mps_(s.best_speed_mps);
  out.elapsed_s_(s.elapsed_s);
  out.rollouts_per_s_(s.rollouts_per_s);
  out.message_(s.message);
  out.has_recommendation_(s.has_recommendation);
  out.recommended_trial_(u32(s.recommendation.trial));
  out.recommended_predicted_cost_(s.recommendation.predicted_cost);
  set_parameters(s.recommendation.params, out, &ros::StudyState_::recommended_param_names_,
                 &ros::StudyState_::recommended_param_values_);
  out.leg_names_(ros_names(s.leg_names));
  for (const domain::SearchAxis& a : s.search_space) {
    out.search_names_().emplace_back(a.name);
    out.search_units_().emplace_back(a.unit.empty() ? std::string("1") : a.unit);
    out.search_low_().push_back(a.low);
    out.search_high_().push_back(a.high);
  }
  return out;
}

ros::TrialRecord_ to_ros(const domain::TrialRecord& t) {
  const domain::RolloutReport& r = t.report;
  const domain::RolloutSummary& m = r.summary;
  ros::TrialRecord_ out;
  out.study_id_(u32(t.study_id));
  out.trial_id_(u32(t.trial_id));
  out.attempt_(u32(r.id.attempt));
  out.initial_(t.initial);
  set_parameters(t.parameters, out, &ros::TrialRecord_::param_names_, &ros::TrialRecord_::param_values_);
  out.worker_id_(r.worker_id);
  out.worker_kind_(ros_kind(r.worker_kind));
  out.outcome_(ros_outcome(r.outcome));
  out.error_(r.error);
  out.cost_(m.cost);
  out.j_feedback_(m.terms.feedback);
  out.j_distance_(m.terms.distance);
  out.j_pitch_(m.terms.pitch);
  out.j_contact_(m.terms.contact);
  out.j_periodicity_(m.terms.periodicity);
  out.late_touchdown_fraction_(m.feedback.late_touchdown);
  out.early_touchdown_fraction_(m.feedback.early_touchdown);
  out.early_toeoff_fraction_(m.feedback.early_toeoff);
  out.late_toeoff_fraction_(m.feedback.late_toeoff);
  out.normalized_torque_(m.normalized_torque);
  out.summed_torque_nm_(m.summed_torque_nm);
  out.fell_(r.fell());
  out.fall_time_s_(m.fall_time_s);
  out.distance_m_(m.distance_m);
  out.mean_speed_mps_(m.mean_speed_mps);
  out.positive_work_j_(m.energy.positive_work_j);
  out.electrical_j_(m.energy.electrical_j);
  out.mechanical_cost_of_transport_(m.energy.mechanical_cost_of_transport);
  out.wall_time_s_(r.wall_time_s);
  // Every leg of the study's robot by name; a report without energy per leg (a rollout that did not run, a
  // synthetic one) has NaN for each, never a leg's value under another leg's name.
  out.leg_names_(ros_names(t.leg_names));
  const bool measured = m.energy.hip.size() == t.leg_names.size() && m.energy.knee.size() == t.leg_names.size();
  const auto values = [&](const PerLeg<JointEnergy>& joints, double JointEnergy::*value) {
    return measured ? per_leg(joints, value) : std::vector<double>(t.leg_names.size(), std::nan(""));
  };
  out.leg_hip_positive_work_j_(values(m.energy.hip, &JointEnergy::positive_work_j));
  out.leg_knee_positive_work_j_(values(m.energy.knee, &JointEnergy::positive_work_j));
  out.leg_hip_electrical_j_(values(m.energy.hip, &JointEnergy::electrical_j));
  out.leg_knee_electrical_j_(values(m.energy.knee, &JointEnergy::electrical_j));
  return out;
}

ros::Worker_ to_ros(const domain::WorkerAnnouncement& w, bool alive) {
  ros::Worker_ out;
  out.worker_id_(w.worker_id);
  out.kind_(ros_kind(w.kind));
  out.host_(w.host);
  out.pid_(w.pid);
  out.slots_(u32(w.slots));
  out.busy_(u32(w.busy));
  out.completed_(w.completed);
  out.accepting_(alive && w.accepting);
  out.heartbeat_period_s_(w.heartbeat_period_s);
  out.status_(w.status);
  out.objective_version_(u32(w.objective_version));
  out.alive_(alive);
  return out;
}

}  // namespace cpgmatch::dds
