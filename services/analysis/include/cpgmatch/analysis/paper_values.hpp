// The numbers Ruppert & Badri-Spröwitz (2022) report for their simulated study, in the same JSON
// shape as to_json(ScienceReport), so that any statistic can be looked up beside its counterpart.
// Strings mark claims the paper makes without a number.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace cpgmatch::analysis {

nlohmann::json paper_values();

// "a.b.c" -> the paper's value there, or null.
nlohmann::json paper_value(const std::string& dotted_path);

}  // namespace cpgmatch::analysis
