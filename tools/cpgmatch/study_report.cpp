#include "study_report.hpp"

#include <chrono>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/chrono.h>
#include <fmt/format.h>

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
    {"fig4", "Fig. 4: the recommended gait over the last 4 s of one rollout: the legs' coupled phases, FL's hip and knee "
             "with stance shaded, and the feedback of FL and FR"},
    {"param_slices", "each parameter against cost, with the GP's partial dependence"},
    {"param_importance", "parameter importance from the GP's length scales"},
    {"param_parallel", "the parameters of every trial as parallel coordinates, coloured by cost"},
    {"sim2real", "simulation against hardware rollouts of the same parameters"},
};

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
  for (const auto& [stem, caption] : kFigures) {
    c.figures.push_back({stem, caption, read_bytes(dir / (std::string(stem) + ".png"))});
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
