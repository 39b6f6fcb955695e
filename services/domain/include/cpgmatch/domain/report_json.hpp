// JSON of the domain types: the study store's schema of a report (the `report` column of a trial and of an
// unspent attempt), and what the command line prints with --json. Field names are part of the store's format:
// stores written by earlier releases read back through report_from_json (fields they lack get their defaults).
#pragma once

#include <nlohmann/json.hpp>

#include "cpgmatch/domain/rollout_report.hpp"
#include "cpgmatch/domain/study_state.hpp"
#include "cpgmatch/domain/worker_announcement.hpp"

namespace cpgmatch::domain {

nlohmann::json to_json(const RolloutReport& report);
// Throws nlohmann::json::exception when a field is missing or has the wrong type, std::runtime_error for an
// outcome this release does not know.
RolloutReport report_from_json(const nlohmann::json& j);

// A report's `energy` object (also `cpgmatch rollout --json`'s): totals, per-metre and cost-of-transport
// figures, and per joint ("hip"/"knee": one entry per leg, in the robot's leg order) work, heat, electrical
// energy and signed mean torque. NaN is null; energy_from_json reads a missing object or key as NaN.
nlohmann::json to_json(const EnergyMeasures& energy);
EnergyMeasures energy_from_json(const nlohmann::json& j);

// With "legs" (the robot's leg names) and "search_space" ([{name, low, high, log, unit}]): what a viewer names
// the study's per-leg and per-parameter values by.
nlohmann::json to_json(const StudyState& state);
nlohmann::json to_json(const WorkerAnnouncement& worker);
// With "legs": the names of its report's per-leg energy entries (energy.joints.hip[i] is leg legs[i]).
nlohmann::json to_json(const TrialRecord& trial);

}  // namespace cpgmatch::domain
