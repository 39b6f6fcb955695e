// Dotted paths into the report JSON ("best.terms.feedback", "windows.0.feedback_mean"): how the tables
// and the replicate aggregation name one statistic.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace cpgmatch::analysis {

// The value at the path, or null when any step is missing. Array steps are 0-based indices.
nlohmann::json json_at(const nlohmann::json& root, const std::string& dotted_path);

// Every number (and boolean, as 0/1) below root, by dotted path, skipping the subtrees named in `skip`
// (top-level keys). Nulls are absent: a statistic that could not be computed is not a zero.
std::map<std::string, double> numeric_leaves(const nlohmann::json& root, const std::vector<std::string>& skip = {});

}  // namespace cpgmatch::analysis
