// The rows of the human tables: which statistics, in which order, under which label. One list for the
// single-study table and the replicate table, so that they always show the same things.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace cpgmatch::analysis {

struct TableRow {
  std::string label;
  std::string path;  // into to_json(ScienceReport), see json_path.hpp; empty: a section heading
  int decimals = 3;
};

// The rows for a report of this shape (its windows included).
std::vector<TableRow> report_rows(const nlohmann::json& report);
// A number with `decimals` digits, a string as is, null as "-".
std::string format_value(const nlohmann::json& value, int decimals);

}  // namespace cpgmatch::analysis
