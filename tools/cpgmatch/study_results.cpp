#include "study_results.hpp"

#include <fstream>

#include <fmt/format.h>

#include "cpgmatch/analysis/stored_study_trials.hpp"
#include "study_report.hpp"

namespace cpgmatch::cli {
namespace {

using nlohmann::json;

// trials.jsonl keeps the shape it always had: one object per rollout, `result` null for a rollout
// that could not run; `enqueued: true` on a gait queued by the study file's `enqueue` (docs/steering.md).
json trial_line(const json& record) {
  const json& report = record["report"];
  json t{{"index", record["trial_id"]}, {"ok", report["ok"]}, {"params", record["params"]}};
  if (record.value("enqueued", false)) t["enqueued"] = true;  // a queued known gait (only then: the shape stays)
  if (report["ok"].get<bool>()) {
    json result = report;
    result["params"] = record["params"];
    t["result"] = result;
    t["cost"] = report["cost"];
  } else {
    t["result"] = nullptr;
    t["cost"] = nullptr;
    t["error"] = report["error"];
  }
  return t;
}

}  // namespace

StudyAnalysis write_study_results(const LocalStudyResult& run, int jitter_draws, bool quiet) {
  {
    std::ofstream trials(run.dir / "trials.jsonl");
    for (const auto& r : run.records) trials << trial_line(r).dump() << '\n';
  }
  // The store, not the DDS records, is the study's record of truth (and what `analyze` reads later).
  const study::StoredStudy stored = analysis::load_stored_study(run.store, run.study_id);
  StudyAnalysis a = analyse_stored_study(stored, jitter_draws, quiet);
  a.json["wall_time_s"] = run.wall_time_s;
  a.json["workers"] = run.workers;
  a.json["store"] = run.store;
  a.json["reissued"] = run.state.value("reissued", json(nullptr));
  std::ofstream(run.dir / "analysis.json") << a.json.dump(2) << '\n';
  if (a.report.best_rollout > 0) {
    std::ofstream yaml(run.dir / "best_params.yaml");
    const auto& rec = a.report.recommendation;
    yaml << fmt::format("# the answer of study '{}': ", a.report.name)
         << (rec ? fmt::format("rollout {}, lowest GP posterior mean {:.4f} (its own rollout cost {:.4f}); lowest single "
                               "cost was rollout {} ({:.4f})\n",
                               rec->rollout, rec->predicted_cost, rec->observed_cost, a.report.best_rollout, a.report.best_cost)
                 : fmt::format("rollout {} (cost {:.4f})\n", a.report.best_rollout, a.report.best_cost));
    for (const auto& [k, v] : analysis::answer_params(a.report)) yaml << k << ": " << v << '\n';
  }
  const analysis::FigureReport figures = write_study_figures(run.dir, a, /*trace_best=*/true, quiet);
  // report.html last: it embeds the figures just drawn.
  try {
    write_study_report(run.dir, a, stored, figures);
  } catch (const std::exception& e) {
    fmt::print(stderr, "report.html: {}\n", e.what());  // the study's results stand without it
  }
  return a;
}

}  // namespace cpgmatch::cli
