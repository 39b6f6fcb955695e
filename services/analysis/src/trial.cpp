#include "cpgmatch/analysis/trial.hpp"

#include <cmath>

#include "cpgmatch/domain/report_json.hpp"

namespace cpgmatch::analysis {
namespace {

double number(const nlohmann::json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return std::nan("");
  return j[key].get<double>();
}

}  // namespace

Trial trial_from_report(int trial_id, const nlohmann::json& report, std::map<std::string, double> params) {
  Trial t;
  t.trial_id = trial_id;
  t.params = std::move(params);
  t.ok = report.is_object() && report.value("ok", false);
  t.hardware = report.is_object() && report.value("worker_kind", std::string()) == "hardware";
  t.synthetic = report.is_object() && report.value("synthetic", false);
  t.outcome = report.is_object() && report.contains("outcome") && report["outcome"].is_string()
                  ? report["outcome"].get<std::string>()
                  : std::string();
  if (!t.ok) return t;
  t.fell = report.value("fell", false);
  t.cost = number(report, "cost");
  const nlohmann::json terms = report.value("terms", nlohmann::json::object());
  t.terms = {number(terms, "feedback"), number(terms, "distance"), number(terms, "pitch"), number(terms, "contact"),
             number(terms, "periodicity")};
  t.normalized_torque = number(report, "normalized_torque");
  t.mean_speed_mps = number(report, "mean_speed_mps");
  t.distance_m = number(report, "distance_m");
  t.summed_torque_nm = number(report, "summed_torque_nm");
  if (!std::isfinite(t.summed_torque_nm)) t.summed_torque_nm = t.normalized_torque * t.mean_speed_mps;
  if (report.contains("energy")) t.energy = domain::energy_from_json(report.at("energy"));
  return t;
}

std::vector<double> unit_point(const Trial& t, const std::map<std::string, Bounds>& bounds) {
  std::vector<double> u;
  u.reserve(bounds.size());
  for (const auto& [name, range] : bounds) {
    const auto it = t.params.find(name);
    const double v = it == t.params.end() ? range.low : it->second;
    const double width = range.high - range.low;
    u.push_back(width > 0.0 ? (v - range.low) / width : 0.5);
  }
  return u;
}

}  // namespace cpgmatch::analysis
