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
  r.fell(result.fell);
  r.fall_time_s(result.fell ? result.fall_time_s : -1.0);
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

std::optional<std::string> check_report(const msg::RolloutReport& r) {
  if (r.worker_id().size() == 0) return std::string("empty worker_id");
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
