// Gait files for `enqueue` (a study file's `enqueue:` key, `cpgmatch study enqueue --params`): parameter files
// like configs/params/default.yaml, read by the client (the optimizer service receives only text and values).
#pragma once

#include <string>
#include <vector>

#include "cpgmatch/domain/command.hpp"

namespace cpgmatch::cli {

// The values a parameter file gives (a flat mapping, or one under `params:`), each name and range checked;
// `shown_as` names it in the gait and in messages. Throws InputError naming file:line and the field.
domain::EnqueuedGait read_gait_file(const std::string& path, const std::string& shown_as);

// The gaits of a study file's `enqueue:` list, each file relative to the study file's folder. Throws
// InputError naming the study file's line for a file that cannot be read.
std::vector<domain::EnqueuedGait> read_enqueued_gaits(const std::string& study_text, const std::string& study_path);

}  // namespace cpgmatch::cli
