#include "cpgmatch/analysis/replicates.hpp"

#include <cmath>

#include <fmt/format.h>

#include "cpgmatch/analysis/json_path.hpp"
#include "cpgmatch/analysis/paper_values.hpp"
#include "cpgmatch/analysis/report_rows.hpp"
#include "cpgmatch/analysis/statistics.hpp"

namespace cpgmatch::analysis {
namespace {

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

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
    s.stats[path] = {static_cast<int>(v.size()), mean(v), sample_sd(v)};
  }
  return s;
}

nlohmann::json to_json(const ReplicateSummary& s) {
  nlohmann::json stats = nlohmann::json::object();
  for (const auto& [path, st] : s.stats) {
    stats[path] = {{"n", st.n}, {"mean", number(st.mean)}, {"sd", number(st.sd)}, {"paper", paper_value(path)}};
  }
  return {{"replicates", s.replicates}, {"statistics", stats}, {"reports", s.reports}};
}

std::string format_table(const ReplicateSummary& s) {
  std::string out = fmt::format("{} replicates: mean ± sd over seeds (n: replicates where defined)\n", s.replicates);
  out += fmt::format("{:<56} {:>22} {:>3}  {}\n", "statistic", "mean ± sd", "n", "paper (one run)");
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
    out += fmt::format("{:<56} {:>22} {:>3}  {}\n", row.label, value, it == s.stats.end() ? 0 : it->second.n,
                       paper.is_null() ? "" : format_value(paper, row.decimals));
  }
  return out;
}

}  // namespace cpgmatch::analysis
