#include "cpgmatch/dds/convert.hpp"

#include <cmath>
#include <set>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/params.hpp"

namespace cpgmatch::dds {

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
  for (const auto& v : values) out[v.name().to_string()] = v.value();
  return out;
}

void fill_report(msg::RolloutReport& r, const RolloutResult& result) {
  const auto& b = result.breakdown;
  r.cost(result.cost);
  r.j_feedback(b.terms.feedback);
  r.j_distance(b.terms.distance);
  r.j_pitch(b.terms.pitch);
  r.j_contact(b.terms.contact);
  r.j_periodicity(b.terms.periodicity);
  r.normalized_torque(b.normalized_torque);
  r.summed_torque_nm(b.summed_torque_nm);
  r.late_touchdown_fraction(b.feedback_fraction.late_touchdown);
  r.early_touchdown_fraction(b.feedback_fraction.early_touchdown);
  r.early_toeoff_fraction(b.feedback_fraction.early_toeoff);
  r.late_toeoff_fraction(b.feedback_fraction.late_toeoff);
  r.outcome(to_wire(result.outcome));
  r.ok(result.outcome == RolloutOutcome::kCompleted || result.outcome == RolloutOutcome::kFell);
  if (!r.ok()) r.error(result.outcome_message.substr(0, 255));
  r.fell(result.outcome == RolloutOutcome::kFell);
  r.fall_time_s(r.fell() ? result.fall_time_s : -1.0);
  r.distance_m(b.distance_m);
  r.mean_speed_mps(b.mean_speed_mps);
  r.wall_time_s(result.wall_time_s);
}

std::optional<std::string> check_parameters(const std::vector<msg::ParameterValue>& values) {
  if (values.empty()) return std::string("no parameters");
  std::set<std::string> seen;
  CpgParameters p;
  for (const auto& v : values) {
    const std::string name = v.name().to_string();
    if (!seen.insert(name).second) return fmt::format("parameter '{}' given twice", name);
    try {
      set_parameter(p, name, v.value(), "candidate");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
  }
  return std::nullopt;
}

msg::RolloutOutcome to_wire(RolloutOutcome outcome) {
  switch (outcome) {
    case RolloutOutcome::kCompleted: return msg::OUTCOME_COMPLETED;
    case RolloutOutcome::kFell: return msg::OUTCOME_FELL;
    case RolloutOutcome::kPlantFault: return msg::OUTCOME_PLANT_FAULT;
    case RolloutOutcome::kDiverged: return msg::OUTCOME_DIVERGED;
  }
  return msg::OUTCOME_ERROR;
}

std::string to_string(msg::RolloutOutcome o) {
  switch (o) {
    case msg::OUTCOME_COMPLETED: return "completed";
    case msg::OUTCOME_FELL: return "fell";
    case msg::OUTCOME_REFUSED: return "refused";
    case msg::OUTCOME_PLANT_FAULT: return "plant_fault";
    case msg::OUTCOME_DIVERGED: return "diverged";
    case msg::OUTCOME_ERROR: return "error";
  }
  return "unknown";
}

std::optional<msg::RolloutOutcome> outcome_from_string(const std::string& name) {
  for (const msg::RolloutOutcome o : {msg::OUTCOME_COMPLETED, msg::OUTCOME_FELL, msg::OUTCOME_REFUSED,
                                      msg::OUTCOME_PLANT_FAULT, msg::OUTCOME_DIVERGED, msg::OUTCOME_ERROR}) {
    if (to_string(o) == name) return o;
  }
  return std::nullopt;
}

bool reissued_not_spent(msg::RolloutOutcome o) {
  return o == msg::OUTCOME_REFUSED || o == msg::OUTCOME_PLANT_FAULT || o == msg::OUTCOME_DIVERGED;
}

std::optional<std::string> check_report(const msg::RolloutReport& r) {
  if (r.worker_id().size() == 0) return std::string("empty worker_id");
  if (static_cast<int>(r.outcome()) < msg::OUTCOME_COMPLETED || static_cast<int>(r.outcome()) > msg::OUTCOME_ERROR) {
    return fmt::format("outcome {} is not a RolloutOutcome", static_cast<int>(r.outcome()));
  }
  const bool ran = r.outcome() == msg::OUTCOME_COMPLETED || r.outcome() == msg::OUTCOME_FELL;
  if (r.ok() != ran) return fmt::format("ok = {} contradicts outcome {}", r.ok(), to_string(r.outcome()));
  if (r.ok() && r.fell() != (r.outcome() == msg::OUTCOME_FELL)) {
    return fmt::format("fell = {} contradicts outcome {}", r.fell(), to_string(r.outcome()));
  }
  if (!r.ok()) return std::nullopt;  // a failed rollout carries only its error
  const std::pair<const char*, double> finite[] = {
      {"cost", r.cost()},          {"j_feedback", r.j_feedback()},   {"j_distance", r.j_distance()},
      {"j_pitch", r.j_pitch()},    {"j_contact", r.j_contact()},     {"j_periodicity", r.j_periodicity()},
      {"distance_m", r.distance_m()}, {"wall_time_s", r.wall_time_s()}};
  for (const auto& [name, value] : finite) {
    if (!std::isfinite(value)) return fmt::format("{} is not finite ({})", name, value);
  }
  if (r.wall_time_s() < 0.0) return std::string("wall_time_s is negative");
  return std::nullopt;
}

std::uint64_t worker_key(const std::string& worker_id) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : worker_id) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

bool worker_id_belongs_to(const std::string& worker_id, const std::string& common_name) {
  if (common_name.empty()) return false;
  if (worker_id == common_name) return true;
  return worker_id.size() > common_name.size() + 1 && worker_id.compare(0, common_name.size(), common_name) == 0 &&
         worker_id[common_name.size()] == '/';
}

std::string to_string(msg::StudyStatus s) {
  switch (s) {
    case msg::STUDY_RUNNING: return "running";
    case msg::STUDY_PAUSED: return "paused";
    case msg::STUDY_DONE: return "done";
    case msg::STUDY_FAILED: return "failed";
    case msg::STUDY_STOPPED: return "stopped";
  }
  return "unknown";
}

std::string to_string(msg::WorkerKind k) { return k == msg::WORKER_HARDWARE ? "hardware" : "sim"; }

}  // namespace cpgmatch::dds
