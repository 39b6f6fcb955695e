// A study's model named by file: `model: calibrated.yaml` in a study file (a path relative to the study
// file), e.g. what `cpgmatch calibrate` wrote. The submitting client reads the file and sends its content
// with the study (with_model_file); the optimizer resolves the spec from that content (StudySpec::resolve),
// so the spec holds the whole model, its hash covers the model's values, and the study section records
// which file they came from (`model: "calibrated.yaml"`). The optimizer never reads a file a client names.
#pragma once

#include <string>

namespace cpgmatch::study {

// The key the client appends with the model file's text; written by the client only, never by hand.
inline constexpr const char* kModelFileTextKey = "model_file_text";

// When the study file's `model` is a file name: the study text with the file's content appended under
// kModelFileTextKey (the study's own lines unchanged, so errors still name its lines). Otherwise the text
// as it is. Throws InputError naming the study file, its line and the model file when the file cannot be
// read, or when the study already has the key.
std::string with_model_file(const std::string& study_yaml, const std::string& study_path);

}  // namespace cpgmatch::study
