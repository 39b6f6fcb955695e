// A study in the SQLite store as the analysis' trial list: done trials in trial order, parameters named
// with the study's own search space (its config is stored beside the trials).
#pragma once

#include <string>

#include "cpgmatch/analysis/trial.hpp"
#include "cpgmatch/study/study_config.hpp"
#include "cpgmatch/study/study_store.hpp"

namespace cpgmatch::analysis {

StudyTrials trials_from_stored_study(const study::StoredStudy& stored);

// Opens the store (it must exist: opening would otherwise create an empty one) and loads one study;
// study_id <= 0 means the last one. Throws InputError naming `--store` or the unknown study id.
study::StoredStudy load_stored_study(const std::string& store_path, int study_id);

}  // namespace cpgmatch::analysis
