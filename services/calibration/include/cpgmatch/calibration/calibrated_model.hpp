// Writes a calibrated model: the start model's YAML text, its comments and sources kept, with each fitted
// value replaced by its estimate and, beside it, the standard deviation and the misfit before and after.
#pragma once

#include <string>
#include <vector>

#include "cpgmatch/calibration/calibration.hpp"

namespace cpgmatch::calibration {

// `model_text` is the start model's YAML (`model_source` names it in messages); `trace_sources` the traces
// fitted. Throws InputError when a fitted value's entry is not on one line (`key: {value: ...}` or
// `key: number`), which is the only form it rewrites. The result loads with sim::parse_model_file.
std::string calibrated_model_text(const std::string& model_text, const std::string& model_source,
                                  const CalibrationResult& result, const std::vector<std::string>& trace_sources);

// The note a calibrated entry carries in place of its source: "calibrated: estimate E +- SD (1 sd) UNIT, from
// START; cost BEFORE -> AFTER; before: PREVIOUS SOURCE" (double quotes in it made single, so that it can be
// written in a double-quoted YAML string). Shared by model files and robot descriptions.
std::string calibrated_source(const FittedValue& value, const CalibrationResult& result, const std::string& previous_source);
// The comment lines a calibrated file starts with: the start and the traces, the residuals, iterations and
// replays, the cost and each channel's RMS misfit before and after.
std::string calibration_header(const std::string& model_source, const CalibrationResult& result,
                               const std::vector<std::string>& trace_sources);

}  // namespace cpgmatch::calibration
