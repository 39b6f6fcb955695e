#include "cpgmatch/analysis/study_export.hpp"
#include "cpgmatch/analysis/stored_study_trials.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "cpgmatch/study/study_config.hpp"

namespace cpgmatch::analysis {

namespace {

using Json = nlohmann::ordered_json;

Json number(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

// A report's number by path ("terms", "feedback"), null when the report lacks it (a failed rollout's).
Json report_number(const nlohmann::json& report, const char* group, const char* key) {
  const nlohmann::json* node = &report;
  if (group) {
    if (!report.is_object() || !report.contains(group) || !report[group].is_object()) return nullptr;
    node = &report[group];
  }
  if (!node->is_object() || !node->contains(key) || !(*node)[key].is_number()) return nullptr;
  return number((*node)[key].get<double>());
}

std::string report_text(const nlohmann::json& report, const char* key) {
  return report.is_object() && report.contains(key) && report[key].is_string() ? report[key].get<std::string>() : "";
}

// How the trial ended. Reports from before outcomes existed: completed or fell when it ran, error when not.
std::string outcome_of(const study::StoredTrial& t) {
  if (t.status != study::TrialStatus::kDone) return "";
  const std::string stored = report_text(t.report, "outcome");
  if (!stored.empty()) return stored;
  if (!t.ok) return "error";
  return t.report.is_object() && t.report.value("fell", false) ? "fell" : "completed";
}

// Where the point came from: the random initial design, the model's proposal, a hardware validation set
// around the answer (never told to the model), or a known gait a user queued (`enqueue`, told as any trial).
std::string source_of(const study::StoredTrial& t, int initial_points) {
  if (t.phase == "validation") return "validation";
  if (t.phase == study::kPhaseEnqueued) return "enqueued";
  return t.trial_id < initial_points ? "initial_design" : "model";
}

}  // namespace

// A report with more legs than names (never written by cpgmatch) names the rest by number.
std::vector<ExportedLegEnergy> leg_energy_of(const nlohmann::json& report, const std::vector<std::string>& legs) {
  std::vector<ExportedLegEnergy> out;
  const nlohmann::json none = nlohmann::json::object();
  const auto member = [&](const nlohmann::json& j, const char* key) -> const nlohmann::json& {
    return j.is_object() && j.contains(key) ? j[key] : none;
  };
  const nlohmann::json& joints = member(member(report, "energy"), "joints");
  const nlohmann::json& hips = member(joints, "hip");
  const nlohmann::json& knees = member(joints, "knee");
  if (!hips.is_array() || !knees.is_array()) return out;
  const std::size_t count = std::max(hips.size(), knees.size());
  for (std::size_t leg = 0; leg < count; ++leg) {
    ExportedLegEnergy e;
    e.leg = leg < legs.size() ? legs[leg] : fmt::format("leg{}", leg + 1);
    for (const auto& [joint, list] : {std::pair<const char*, const nlohmann::json*>{"hip", &hips}, {"knee", &knees}}) {
      const nlohmann::json& values = leg < list->size() ? (*list)[leg] : none;
      for (const char* key : {"positive_work_j", "joule_loss_j", "electrical_j", "signed_mean_torque_nm"}) {
        e.values[fmt::format("{}_{}", joint, key)] = report_number(values, nullptr, key);
      }
    }
    out.push_back(std::move(e));
  }
  return out;
}

ExportedStudy export_study(const study::StoredStudy& stored) {
  const study::StudyConfig cfg = stored_study_config(stored);  // a damaged text blames the store
  ExportedStudy s;
  s.study_id = stored.study_id;
  s.name = stored.name;
  s.state = stored.state;
  s.message = stored.message;
  s.created_at_s = stored.created_at_s;
  s.spec_sha256 = stored.spec.sha256;
  s.parameters = cfg.space.dimensions();
  s.fixed = cfg.space.fixed();
  s.legs = stored_study_leg_names(stored);
  for (const auto& t : stored.trials) {
    ExportedTrial row;
    const bool done = t.status == study::TrialStatus::kDone;
    const nlohmann::json& r = t.report;
    row.done = done;
    row.ok = done && t.ok;
    row.cost = t.cost;
    row.issued_at_s = t.issued_at_s;
    row.reported_at_s = t.reported_at_s;
    const std::map<std::string, double> named = cfg.space.to_named(t.x);
    for (const auto& p : s.parameters) row.params[p.name] = named.at(p.name);
    Json& c = row.columns;
    c["study_id"] = stored.study_id;
    c["study_name"] = stored.name;
    c["trial_id"] = t.trial_id;
    c["rollout"] = t.trial_id + 1;
    c["state"] = study::to_string(t.status);
    c["phase"] = t.phase;
    c["source"] = source_of(t, cfg.optimizer.initial_points);
    c["outcome"] = outcome_of(t);
    c["ok"] = row.ok;
    c["fell"] = row.ok && r.is_object() && r.value("fell", false);
    c["cost"] = row.ok ? number(t.cost) : Json(nullptr);
    for (const char* term : {"feedback", "distance", "pitch", "contact", "periodicity"}) {
      c[fmt::format("J_{}", term)] = report_number(r, "terms", term);
    }
    for (const char* mechanism : {"late_touchdown", "early_touchdown", "early_toeoff", "late_toeoff"}) {
      c[fmt::format("feedback_{}", mechanism)] = report_number(r, "feedback_fraction", mechanism);
    }
    c["normalized_torque"] = report_number(r, nullptr, "normalized_torque");  // eq. 1, N m / (m/s)
    c["summed_torque_nm"] = report_number(r, nullptr, "summed_torque_nm");
    c["mean_speed_mps"] = report_number(r, nullptr, "mean_speed_mps");
    c["distance_m"] = report_number(r, nullptr, "distance_m");
    const Json fall_time = report_number(r, nullptr, "fall_time_s");  // -1 when it did not fall
    c["fall_time_s"] = c["fell"].get<bool>() ? fall_time : Json(nullptr);
    c["worker_id"] = t.worker_id;
    c["worker_kind"] = report_text(r, "worker_kind");
    // A service benchmark's synthetic cost (cpgmatch-sim-worker --fake-rollout-ms): no gait was simulated.
    c["synthetic"] = r.is_object() && r.value("synthetic", false);
    c["attempt"] = t.attempt;
    c["faults"] = t.faults;
    c["issued_at"] = number(t.issued_at_s);
    c["reported_at"] = done ? number(t.reported_at_s) : Json(nullptr);
    c["wall_time_s"] = report_number(r, nullptr, "wall_time_s");
    c["error"] = report_text(r, "error");
    if (done) row.leg_energy = leg_energy_of(r, s.legs);
    if (t.proposal) {
      const study::HardwareProposalRecord& p = *t.proposal;
      row.hardware_proposal = Json::object();
      row.hardware_proposal["fall_probability"] = number(p.fall_probability);
      row.hardware_proposal["within_fall_limit"] = p.within_fall_limit;
      row.hardware_proposal["cost_bound"] = number(p.cost_bound);
      row.hardware_proposal["cost_limit"] = p.cost_limit ? number(*p.cost_limit) : Json(nullptr);
      row.hardware_proposal["within_cost_bound"] = p.within_cost_bound;
      row.hardware_proposal["basis"] = p.basis;
    }
    s.trials.push_back(std::move(row));
  }
  return s;
}

namespace {

std::string csv_cell(const Json& v) {
  if (v.is_null()) return "";
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_number_float()) return fmt::format("{}", v.get<double>());  // shortest text that reads back the same double
  if (v.is_number()) return v.dump();
  const std::string text = v.is_string() ? v.get<std::string>() : v.dump();
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char ch : text) quoted += ch == '"' ? std::string("\"\"") : std::string(1, ch);
  return quoted + "\"";
}

}  // namespace

std::string leg_energy_column(const std::string& leg, const std::string& key) {
  return fmt::format("leg_energy.{}.{}", leg, key);
}

std::string hardware_proposal_column(const std::string& key) { return "hardware_proposal." + key; }

void write_csv(const std::vector<ExportedStudy>& studies, std::ostream& out) {
  std::vector<std::string> columns;
  std::vector<std::string> params;
  std::set<std::string> seen_params;
  // Per-leg columns in the order of first appearance: one robot's legs in its order, then another's new ones.
  std::vector<std::string> leg_columns;
  std::set<std::string> seen_leg_columns;
  // After everything else, and only when some trial is a hardware proposal with its check: a store without
  // any exports the columns it did before.
  std::vector<std::string> proposal_keys;
  for (const auto& s : studies) {
    for (const auto& t : s.trials) {
      if (columns.empty()) {
        for (const auto& item : t.columns.items()) columns.push_back(item.key());
      }
      for (const auto& leg : t.leg_energy) {
        for (const auto& item : leg.values.items()) {
          const std::string name = leg_energy_column(leg.leg, item.key());
          if (seen_leg_columns.insert(name).second) leg_columns.push_back(name);
        }
      }
      if (proposal_keys.empty() && t.hardware_proposal.is_object()) {
        for (const auto& item : t.hardware_proposal.items()) proposal_keys.push_back(item.key());
      }
    }
    for (const auto& p : s.parameters) {
      if (seen_params.insert(p.name).second) params.push_back(p.name);
    }
  }
  if (columns.empty()) {  // no trial at all: still a header a reader understands
    columns = {"study_id", "study_name", "trial_id", "rollout", "state", "cost"};
  }
  for (std::size_t i = 0; i < columns.size(); ++i) out << (i ? "," : "") << columns[i];
  for (const auto& p : params) out << ",params_" << p;
  for (const auto& l : leg_columns) out << ',' << csv_cell(Json(l));
  for (const auto& k : proposal_keys) out << ',' << csv_cell(Json(hardware_proposal_column(k)));
  out << '\n';
  for (const auto& s : studies) {
    for (const auto& t : s.trials) {
      for (std::size_t i = 0; i < columns.size(); ++i) {
        out << (i ? "," : "") << (t.columns.contains(columns[i]) ? csv_cell(t.columns[columns[i]]) : std::string());
      }
      for (const auto& p : params) {
        const auto it = t.params.find(p);
        out << ',' << (it == t.params.end() ? std::string() : csv_cell(Json(it->second)));
      }
      std::map<std::string, Json> by_column;
      for (const auto& leg : t.leg_energy) {
        for (const auto& item : leg.values.items()) by_column[leg_energy_column(leg.leg, item.key())] = item.value();
      }
      for (const auto& l : leg_columns) {
        const auto it = by_column.find(l);
        out << ',' << (it == by_column.end() ? std::string() : csv_cell(it->second));
      }
      for (const auto& k : proposal_keys) {
        const bool has = t.hardware_proposal.is_object() && t.hardware_proposal.contains(k);
        out << ',' << (has ? csv_cell(t.hardware_proposal[k]) : std::string());
      }
      out << '\n';
    }
  }
}

nlohmann::ordered_json export_json(const std::vector<ExportedStudy>& studies) {
  Json all = Json::array();
  for (const auto& s : studies) {
    Json parameters = Json::array();
    for (const auto& p : s.parameters) {
      parameters.push_back({{"name", p.name}, {"low", p.low}, {"high", p.high}, {"log", p.log_scale}, {"unit", p.unit}});
    }
    Json trials = Json::array();
    for (const auto& t : s.trials) {
      Json row = t.columns;
      row["params"] = Json(t.params);
      Json legs = Json::object();
      for (const auto& leg : t.leg_energy) legs[leg.leg] = leg.values;
      row["leg_energy"] = legs;
      if (t.hardware_proposal.is_object()) row["hardware_proposal"] = t.hardware_proposal;
      trials.push_back(std::move(row));
    }
    all.push_back({{"study_id", s.study_id},
                   {"name", s.name},
                   {"state", s.state},
                   {"message", s.message},
                   {"created_at", s.created_at_s},
                   {"spec_sha256", s.spec_sha256},
                   {"parameters", parameters},
                   {"fixed", Json(s.fixed)},
                   {"legs", s.legs},
                   {"trials", trials}});
  }
  return {{"format", "cpgmatch-export-1"}, {"studies", all}};
}

}  // namespace cpgmatch::analysis
