#include "cpgmatch/analysis/optuna_journal.hpp"

#include <time.h>

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>

namespace cpgmatch::analysis {

namespace {

using Json = nlohmann::ordered_json;

// Optuna's operation codes (JournalOperation) and the values of the enums it stores as integers.
constexpr int kCreateStudy = 0;
constexpr int kSetStudyUserAttr = 2;
constexpr int kCreateTrial = 4;
constexpr int kMinimize = 1;  // StudyDirection.MINIMIZE
constexpr int kRunning = 0, kComplete = 1, kFail = 3;  // TrialState
// Optuna ignores the writer's id of a replayed log unless it is its own process': any fixed text serves.
const char* const kWriter = "cpgmatch-export";

// Optuna's datetimes: ISO 8601 in local time without a zone, microseconds (datetime.isoformat).
std::string iso_local(double unix_s) {
  const double whole = std::floor(unix_s);
  const time_t t = static_cast<time_t>(whole);
  struct tm local {};
  localtime_r(&t, &local);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &local);
  const int micros = std::min(999999, static_cast<int>(std::lround((unix_s - whole) * 1e6)));
  return fmt::format("{}.{:06d}", buf, micros);
}

// optuna.distributions.distribution_to_json: the distribution as a JSON *string* inside the log line.
std::string float_distribution(double low, double high, bool log) {
  return Json({{"name", "FloatDistribution"}, {"attributes", {{"step", nullptr}, {"low", low}, {"high", high}, {"log", log}}}})
      .dump();
}

Json log_line(int op, Json fields) {
  Json line = {{"op_code", op}, {"worker_id", kWriter}};
  for (auto& item : fields.items()) line[item.key()] = item.value();
  return line;
}

}  // namespace

std::vector<std::string> write_optuna_journal(const std::vector<ExportedStudy>& studies, std::ostream& out) {
  std::map<std::string, int> uses;
  for (const auto& s : studies) ++uses[s.name];
  std::vector<std::string> names;
  int journal_id = 0;  // Optuna numbers studies 0, 1, ... in the order the journal creates them
  for (const auto& s : studies) {
    const std::string name = uses[s.name] > 1 ? fmt::format("{} (study {})", s.name, s.study_id) : s.name;
    names.push_back(name);
    out << log_line(kCreateStudy, {{"study_name", name}, {"directions", {kMinimize}}}).dump() << '\n';
    const Json attributes = {{"cpgmatch_study_id", s.study_id}, {"cpgmatch_state", s.state},
                             {"cpgmatch_message", s.message}, {"cpgmatch_spec_sha256", s.spec_sha256},
                             {"cpgmatch_fixed_parameters", Json(s.fixed)}, {"cpgmatch_legs", Json(s.legs)}};
    for (const auto& item : attributes.items()) {
      out << log_line(kSetStudyUserAttr, {{"study_id", journal_id}, {"user_attr", {{item.key(), item.value()}}}}).dump() << '\n';
    }
    for (const auto& t : s.trials) {
      Json distributions = Json::object(), params = Json::object();
      for (const auto& p : s.parameters) {
        const double v = t.params.at(p.name);
        // A value outside the range (never from the optimizer) widens that trial's range instead of being lost.
        distributions[p.name] = float_distribution(std::min(p.low, v), std::max(p.high, v), p.log_scale);
        params[p.name] = v;  // a FloatDistribution's internal representation is the value itself
      }
      Json user_attrs = Json::object();
      for (const auto& item : t.columns.items()) {
        if (item.key() != "study_id" && item.key() != "study_name" && item.key() != "cost") user_attrs[item.key()] = item.value();
      }
      // Per leg by the robot's leg name, as the CSV's columns (leg_energy.L1.hip_positive_work_j).
      for (const auto& leg : t.leg_energy) {
        for (const auto& item : leg.values.items()) user_attrs[leg_energy_column(leg.leg, item.key())] = item.value();
      }
      if (t.hardware_proposal.is_object()) {
        for (const auto& item : t.hardware_proposal.items()) user_attrs[hardware_proposal_column(item.key())] = item.value();
      }
      const double start_s = t.issued_at_s > 0.0 ? t.issued_at_s : s.created_at_s;
      Json fields = {{"study_id", journal_id},
                     {"datetime_start", iso_local(start_s)},
                     {"state", !t.done ? kRunning : t.ok && std::isfinite(t.cost) ? kComplete : kFail},
                     {"value", t.done && t.ok && std::isfinite(t.cost) ? Json(t.cost) : Json(nullptr)},
                     {"values", nullptr}};
      if (t.done) fields["datetime_complete"] = iso_local(std::max(start_s, t.reported_at_s));
      fields["distributions"] = distributions;
      fields["params"] = params;
      fields["user_attrs"] = user_attrs;
      fields["system_attrs"] = Json::object();
      fields["intermediate_values"] = Json::object();
      out << log_line(kCreateTrial, fields).dump() << '\n';
    }
    ++journal_id;
  }
  return names;
}

}  // namespace cpgmatch::analysis
