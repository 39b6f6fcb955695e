// report.html: one self-contained page a person reads and keeps (figures embedded as data: URIs, style
// inlined, no script, no link outside the file), so it opens offline, mailed or archived, as it was written.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace cpgmatch::cli {

struct ReportFigure {
  std::string stem;     // e.g. "fig5a"
  std::string caption;  // what it shows, in words
  std::string png;      // the PNG file's bytes; empty: not drawn
};

struct ReportContent {
  std::string title;                                        // e.g. "paper-study (study 1)"
  std::string generated_by;                                 // program, version, time
  std::vector<std::pair<std::string, std::string>> facts;   // the study at a glance
  std::string science_table;                                // analysis::format_table (what `analyze` prints)
  std::string sim2real_text;                                // empty without hardware rollouts
  nlohmann::json report;                                    // to_json(ScienceReport): best and recommended gait
  std::vector<ReportFigure> figures;
  std::vector<std::string> not_drawn;                       // what the data could not give, in words
  std::string study_yaml;                                   // the study file as submitted
  std::string spec_json;                                    // the resolved spec (model, settings, bounds)
};

std::string report_html(const ReportContent& content);

std::string html_escape(std::string_view text);
std::string base64(std::string_view bytes);

}  // namespace cpgmatch::cli
