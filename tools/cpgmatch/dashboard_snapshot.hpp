// What the dashboard page shows, as one JSON document: every study on the domain with its trials reduced to
// what the charts draw, and the workers with what they last ran. Plain JSON in and out (the to_json shapes
// of StudyState, WorkerAnnouncement and TrialRecord that StudyClient gives), so it is tested without DDS.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace cpgmatch::cli::dashboard {

// Everything one DDS client has heard on its domain.
struct DomainView {
  int domain = 0;
  bool optimizer_heard = false;                            // an optimizer's state writer is matched
  std::map<int, nlohmann::json> states;                    // by study id
  std::map<std::string, nlohmann::json> workers;           // by worker id
  std::map<int, std::vector<nlohmann::json>> trials;       // by study id, in trial id order
};

// One trial as the page draws it: id, initial, outcome, ok, fell, cost, the five cost terms, the searched
// parameters, the worker, speed and normalised torque (the report's energy and loop details are left out:
// the page draws none of them, and they would make every update several times larger).
nlohmann::json trial_summary(const nlohmann::json& record);

// The best cost so far after each trial, in the order given; null until the first trial that ran (an
// evaluation that could not run has no cost). The same rule as Fig. 5a (analysis::current_minimum).
nlohmann::json current_minimum(const std::vector<nlohmann::json>& summaries);

// {"domain", "optimizer_heard", "studies": [{"state", "trials", "current_minimum", "parameters", "legs",
//  "leg_energy"}],
//  "workers": [{..announcement.., "last_trial": {"study_id", "trial_id", "outcome"} or null}]}
// Studies newest first (the one a user just submitted is on top); workers by id. "parameters": the searched
// names in the study's search space's order (its state's search_space), "legs": its robot's legs by name,
// "leg_energy": {"trial_id", "recommended", "legs": [{"leg", hip/knee positive work and electrical energy,
// J}]} of the answer's trial, or null (not measured yet, or an older optimizer's that names no legs).
nlohmann::json snapshot_json(const DomainView& view);

}  // namespace cpgmatch::cli::dashboard
