#include "study_report.hpp"

#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/chrono.h>
#include <fmt/format.h>

#include "cpgmatch/analysis/stored_study_trials.hpp"
#include "cpgmatch/analysis/study_export.hpp"
#include "cpgmatch/runtime/version.hpp"
#include "report_html.hpp"

namespace cpgmatch::cli {

namespace fs = std::filesystem;

namespace {

// The figures a study's folder can hold, in reading order, with what each shows.
const std::vector<std::pair<const char*, const char*>> kFigures = {
    {"fig5a", "Fig. 5a: cost per rollout and its current minimum (falls in a band of their own above)"},
    {"fig5b", "Fig. 5b: every cost term per rollout, log scale (falls above, terms below the axis' floor below)"},
    {"fig6", "Fig. 6: normalised torque of the rollouts that walked, sorted by cost, falls shaded"},
    {"fig6_cot", "electrical cost of transport of the same rollouts, in Fig. 6's order"},
    {"fig4", ""},  // fig4_caption: it names the robot's legs
    {"param_slices", "each parameter against cost, with the GP's partial dependence"},
    {"param_importance", "parameter importance from the GP's length scales"},
    {"param_parallel", "the parameters of every trial as parallel coordinates, coloured by cost"},
    {"sim2real", "simulation against hardware rollouts of the same parameters"},
};

// The rollout whose energy per leg the report shows: the answer (the recommendation, else the lowest cost).
std::pair<int, std::string> answer_rollout(const analysis::ScienceReport& r) {
  if (r.recommendation) return {r.recommendation->rollout, fmt::format("rollout {} (recommended)", r.recommendation->rollout)};
  return {r.best_rollout, fmt::format("rollout {} (lowest cost)", r.best_rollout)};
}

std::vector<ReportLegEnergy> leg_energy_of_rollout(const study::StoredStudy& stored, int rollout,
                                                  const std::vector<std::string>& legs) {
  std::vector<ReportLegEnergy> out;
  for (const auto& t : stored.trials) {
    if (t.trial_id != rollout - 1 || t.status != study::TrialStatus::kDone) continue;  // rollout = trial id + 1
    for (const auto& leg : analysis::leg_energy_of(t.report, legs)) {
      const auto value = [&](const char* key) {
        const auto& v = leg.values[key];
        return v.is_number() ? v.get<double>() : std::nan("");
      };
      out.push_back({leg.leg, value("hip_positive_work_j"), value("knee_positive_work_j"), value("hip_electrical_j"),
                     value("knee_electrical_j")});
    }
  }
  return out;
}

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

std::string utc(double unix_s) {
  const auto t = std::chrono::system_clock::time_point(
      std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::duration<double>(unix_s)));
  return fmt::format("{:%Y-%m-%d %H:%M} UTC", fmt::gmtime(std::chrono::system_clock::to_time_t(t)));
}

std::string pretty_json(const std::string& text) {
  if (text.empty()) return {};
  try {
    return nlohmann::json::parse(text).dump(2);
  } catch (const nlohmann::json::exception&) {
    return text;  // shown as stored
  }
}

}  // namespace

fs::path write_study_report(const fs::path& dir, const StudyAnalysis& a, const study::StoredStudy& stored,
                            const analysis::FigureReport& figures) {
  const analysis::ScienceReport& r = a.report;
  ReportContent c;
  c.title = fmt::format("{} (study {})", stored.name, stored.study_id);
  const double now_s = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  c.generated_by = fmt::format("{}, {}", runtime::version_text("cpgmatch"), utc(now_s));
  c.facts = {
      {"study", fmt::format("{} \u00b7 {}", stored.study_id, stored.name)},
      {"state", stored.message.empty() ? stored.state : fmt::format("{} ({})", stored.state, stored.message)},
      {"study file", stored.source_name},
      {"created", stored.created_at_s > 0 ? utc(stored.created_at_s) : std::string("-")},
      {"rollouts", fmt::format("{} ({} from the initial design, {} could not run)", r.rollouts, r.initial_points,
                               r.failed_evaluations)},
      {"falls", fmt::format("{} ({} in the initial design, {} after)", r.falls, r.falls_initial, r.falls_after)},
      {"lowest cost", r.best_rollout > 0 ? fmt::format("{:.4f} (rollout {}, trial {})", r.best_cost, r.best_rollout,
                                                       r.best_rollout - 1)  // analysis: rollout = trial id + 1
                                         : "-"},
      {"terrain, seed", fmt::format("{}, {}", a.config.terrain, a.trials.seed)},
  };
  c.science_table = analysis::format_table(r);
  c.sim2real_text = a.sim2real_text;
  c.report = a.json;
  for (const auto& d : a.config.space.dimensions()) c.parameters.push_back({d.name, d.unit, d.low, d.high});
  c.legs = analysis::stored_study_leg_names(stored);
  const auto [rollout, rollout_words] = answer_rollout(r);
  c.leg_energy_rollout = rollout_words;
  if (rollout > 0) c.leg_energy = leg_energy_of_rollout(stored, rollout, c.legs);
  for (const auto& [stem, caption] : kFigures) {
    const std::string words = std::string(stem) == "fig4" ? fig4_caption(c.legs) : std::string(caption);
    c.figures.push_back({stem, words, read_bytes(dir / (std::string(stem) + ".png"))});
  }
  c.not_drawn = figures.not_drawn;
  for (const std::string& failure : figures.failed) c.not_drawn.push_back("failed: " + failure);
  c.study_yaml = stored.config_yaml;
  c.spec_json = pretty_json(stored.spec.json);

  const fs::path path = dir / "report.html";
  std::ofstream out(path, std::ios::binary);
  out << report_html(c);
  if (!out.flush()) throw std::runtime_error(fmt::format("cannot write {}", path.string()));
  return path;
}

}  // namespace cpgmatch::cli
