// A study in the SQLite store as the analysis' trial list: done trials in trial order, parameters named
// with the study's own search space (its config is stored beside the trials).
#pragma once

#include <string>
#include <vector>

#include "cpgmatch/analysis/trial.hpp"
#include "cpgmatch/study/study_config.hpp"
#include "cpgmatch/study/study_store.hpp"

namespace cpgmatch::analysis {

StudyTrials trials_from_stored_study(const study::StoredStudy& stored);

// The study's config from its stored text. A stored text that does not load is the store's damage, not the
// study file's: std::runtime_error "the store's copy of study N (from FILE) is damaged: ...", never an
// InputError that would send the user to a study file that may be fine.
study::StudyConfig stored_study_config(const study::StoredStudy& stored);

// The study's legs by name, in the order its reports list per-leg values (energy per leg, trace columns): its
// robot's (the spec's), else Morti's FL FR HL HR (a study of Morti's model file, or a store from before specs).
// A damaged spec is the store's damage, as in stored_study_config.
std::vector<std::string> stored_study_leg_names(const study::StoredStudy& stored);

// std::runtime_error naming every unreadable trial of the studies (StoredStudy::unreadable_trials), when
// there is one: a reader exports or reports every trial, or none, never a silent subset.
void require_every_trial_readable(const std::vector<study::StoredStudy>& studies, const std::string& store_path);

// Opens the store read-only (it must exist and be a cpgmatch store) and loads one study; study_id <= 0 means
// the last one. Throws InputError naming `--store` or the unknown study id, std::runtime_error naming each
// trial of the study that cannot be read.
study::StoredStudy load_stored_study(const std::string& store_path, int study_id);

}  // namespace cpgmatch::analysis
