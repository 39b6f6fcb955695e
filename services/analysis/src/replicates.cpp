#include "cpgmatch/analysis/replicates.hpp"

#include <cmath>

#include <fmt/format.h>

#include "cpgmatch/analysis/energy_claim.hpp"
#include "cpgmatch/analysis/json_path.hpp"
#include "cpgmatch/analysis/paper_values.hpp"
#include "cpgmatch/analysis/report_rows.hpp"
#include "cpgmatch/analysis/statistics.hpp"

namespace cpgmatch::analysis {
namespace {

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

// The statistics whose every seed matters, not only their mean (issue 26's targets).
std::vector<std::pair<std::string, std::string>> per_seed_rows() {
  return {{"J_feedback ratio last / initial", "learning.feedback_ratio"},
          {"falls after the initial design", "falls.after"},
          {"rho J_feedback, electrical CoT at equal speed (partial)",
           "measures.electrical_cost_of_transport.rho_feedback_partial"},
          {"electrical CoT ratio last / initial", "measures.electrical_cost_of_transport.ratio"},
          {"mean speed, last window, m/s", "windows.3.speed_mean_mps"}};
}

}  // namespace

ReplicateSummary aggregate_replicates(const std::vector<nlohmann::json>& reports) {
  ReplicateSummary s;
  s.replicates = static_cast<int>(reports.size());
  s.reports = reports;
  std::map<std::string, std::vector<double>> samples;
  for (const auto& r : reports) {
    for (const auto& [path, value] : numeric_leaves(r, {"paper", "study_id"})) {
      if (path.rfind("jitter.costs.", 0) == 0) continue;  // individual draws, summarised by jitter.cost_*
      samples[path].push_back(value);
    }
  }
  for (const auto& [path, v] : samples) {
    ReplicateStat& st = s.stats[path];
    st.n = static_cast<int>(v.size());
    st.mean = mean(v);
    st.sd = sample_sd(v);
    st.sign_reference = sign_reference(path);
    if (st.sign_reference) st.sign = sign_test(v, *st.sign_reference);
  }
  return s;
}

std::optional<double> sign_reference(const std::string& path) {
  const std::string leaf = path.substr(path.rfind('.') + 1);
  if (leaf.rfind("rho", 0) == 0 || path.rfind("correlations.feedback_vs_", 0) == 0) return 0.0;
  if (leaf == "ratio" || (leaf.size() > 6 && leaf.compare(leaf.size() - 6, 6, "_ratio") == 0)) return 1.0;
  return std::nullopt;
}

nlohmann::json to_json(const ReplicateSummary& s) {
  nlohmann::json stats = nlohmann::json::object();
  for (const auto& [path, st] : s.stats) {
    stats[path] = {{"n", st.n}, {"mean", number(st.mean)}, {"sd", number(st.sd)}, {"paper", paper_value(path)}};
    if (st.sign_reference) {
      stats[path]["sign_test"] = {{"reference", *st.sign_reference},
                                  {"above", st.sign.above},
                                  {"below", st.sign.below},
                                  {"p_two_sided", st.sign.p_two_sided}};
    }
  }
  return {{"replicates", s.replicates}, {"statistics", stats}, {"reports", s.reports}};
}

std::string format_table(const ReplicateSummary& s) {
  std::string out = fmt::format("{} replicates: mean ± sd over seeds (n: replicates where defined)\n", s.replicates);
  out += fmt::format("{:<56} {:>22} {:>3} {:>18}  {}\n", "statistic", "mean ± sd", "n", "seeds +/- (sign p)",
                     "paper (one run)");
  if (s.reports.empty()) return out;
  for (const auto& row : report_rows(s.reports.front())) {
    if (row.path.empty()) {
      out += row.label + "\n";
      continue;
    }
    const auto it = s.stats.find(row.path);
    const std::string value =
        it == s.stats.end() ? "-"
                            : fmt::format("{} ± {}", format_value(number(it->second.mean), row.decimals + 1),
                                          format_value(number(it->second.sd), row.decimals + 1));
    const nlohmann::json paper = paper_value(row.path);
    std::string sign;
    if (it != s.stats.end() && it->second.sign_reference) {
      // Above the reference first: for a rho "+", for a ratio "> 1" (got worse).
      sign = fmt::format("{}/{} ({:.3f})", it->second.sign.above, it->second.sign.below, it->second.sign.p_two_sided);
    }
    out += fmt::format("{:<56} {:>22} {:>3} {:>18}  {}\n", row.label, value, it == s.stats.end() ? 0 : it->second.n,
                       sign, paper.is_null() ? "" : format_value(paper, row.decimals));
  }
  const auto share = s.stats.find("eq1.knee_steady_share_median");
  out += eq1_sentence(share == s.stats.end() ? std::nan("") : share->second.mean) + "\n";
  out += "per seed (seed order):\n";
  for (const auto& [label, path] : per_seed_rows()) {
    out += fmt::format("  {:<54}", label);
    for (const auto& r : s.reports) out += fmt::format(" {}", format_value(json_at(r, path), 3));
    out += "\n";
  }
  return out;
}

}  // namespace cpgmatch::analysis
