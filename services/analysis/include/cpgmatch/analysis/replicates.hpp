// N replicates of one study (different seeds): every scalar statistic of their science reports as
// mean ± sd, beside the paper's single run. One run of a stochastic optimiser is an anecdote; the
// spread across seeds says whether a difference from the paper means anything.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cpgmatch/analysis/statistics.hpp"

namespace cpgmatch::analysis {

struct ReplicateStat {
  int n = 0;          // replicates in which the statistic could be computed
  double mean = 0.0;
  double sd = 0.0;    // sample sd; NaN for n < 2
  // For a correlation (against 0) and a learning ratio (against 1): on how many seeds it lies on either
  // side, and the sign test's two-sided p. A mean can come from a few large seeds; the sign test asks
  // whether the effect is there seed after seed.
  std::optional<double> sign_reference;
  SignTest sign;
};

struct ReplicateSummary {
  int replicates = 0;
  std::map<std::string, ReplicateStat> stats;  // by dotted path into to_json(ScienceReport)
  std::vector<nlohmann::json> reports;         // the inputs, for the table's row list and the plots
};

// The statistics whose sign is the claim: Spearman rhos (against 0) and learning ratios (against 1).
std::optional<double> sign_reference(const std::string& dotted_path);

// `reports` are to_json(ScienceReport) objects. Identifiers (study_id) and the paper's values are not
// statistics and are left out.
ReplicateSummary aggregate_replicates(const std::vector<nlohmann::json>& reports);

nlohmann::json to_json(const ReplicateSummary& s);
std::string format_table(const ReplicateSummary& s);

}  // namespace cpgmatch::analysis
