// What a finished local study leaves in its results folder: trials.jsonl, best_params.yaml,
// analysis.json (the science report), the figures and report.html. Shared by `study run` and `reproduce`.
#pragma once

#include "local_study.hpp"
#include "study_analysis.hpp"

namespace cpgmatch::cli {

StudyAnalysis write_study_results(const LocalStudyResult& run, int jitter_draws, bool quiet);

}  // namespace cpgmatch::cli
