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

// One searched parameter as the study's search space names it (the robot's names, bounds and units).
struct ReportParameter {
  std::string name;
  std::string unit;  // SI ("rad", "Hz"); "1" or empty: dimensionless (a fraction of a cycle)
  double low = 0.0;
  double high = 0.0;
};

// One leg's motors in one rollout, by the robot's name for the leg (J; NaN: not measured).
struct ReportLegEnergy {
  std::string leg;
  double hip_positive_work_j = 0.0;
  double knee_positive_work_j = 0.0;
  double hip_electrical_j = 0.0;
  double knee_electrical_j = 0.0;
};

struct ReportContent {
  std::string title;                                        // e.g. "paper-study (study 1)"
  std::string generated_by;                                 // program, version, time
  std::vector<std::pair<std::string, std::string>> facts;   // the study at a glance
  std::string science_table;                                // analysis::format_table (what `analyze` prints)
  std::string sim2real_text;                                // empty without hardware rollouts
  nlohmann::json report;                                    // to_json(ScienceReport): best and recommended gait
  std::vector<ReportParameter> parameters;                  // the search space, in its order
  std::vector<std::string> legs;                            // the robot's legs by name, in its order
  std::string leg_energy_rollout;                           // whose energy per leg is shown, in words
  std::vector<ReportLegEnergy> leg_energy;                  // one per leg; empty: no energy measured
  std::vector<ReportFigure> figures;
  std::vector<std::string> not_drawn;                       // what the data could not give, in words
  std::string study_yaml;                                   // the study file as submitted
  std::string spec_json;                                    // the resolved spec (model, settings, bounds)
};

std::string report_html(const ReportContent& content);

// Fig. 4's caption for a robot's legs (it draws the first leg's joints and the first two legs' feedback).
std::string fig4_caption(const std::vector<std::string>& legs);

std::string html_escape(std::string_view text);
std::string base64(std::string_view bytes);

}  // namespace cpgmatch::cli
