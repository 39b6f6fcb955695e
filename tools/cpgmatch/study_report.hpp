// Writes report.html (report_html.hpp) for a stored study whose figures are already in `dir`: what `cpgmatch
// report`, `study run` and `reproduce` leave for people to read.
#pragma once

#include <filesystem>

#include "cpgmatch/analysis/plots.hpp"
#include "cpgmatch/study/study_store.hpp"
#include "study_analysis.hpp"

namespace cpgmatch::cli {

// dir/report.html from the analysis, the stored study (its file and spec) and what drawing the figures came to
// (`figures.not_drawn` is said in the report; the PNGs are read from dir). Returns the file's path; throws
// std::runtime_error when it cannot be written.
std::filesystem::path write_study_report(const std::filesystem::path& dir, const StudyAnalysis& a,
                                         const study::StoredStudy& stored, const analysis::FigureReport& figures);

}  // namespace cpgmatch::cli
