// A stored study's trials as a table other tools read: one row per trial with its parameters, cost, every
// cost term, the feedback per mechanism, torque, speed, whether it fell, its worker, where it came from and
// how it ended. `cpgmatch export` writes it as CSV (pandas, a spreadsheet), JSON, or an Optuna journal
// (optuna_journal.hpp). Read through the store's API; the store itself is not touched.
#pragma once

#include <map>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cpgmatch/bo/search_space.hpp"
#include "cpgmatch/study/study_store.hpp"

namespace cpgmatch::analysis {

// What one leg's motors spent in a rollout (the report's energy, per joint of the leg), named by the robot's
// leg: the keys hip_positive_work_j, hip_joule_loss_j, hip_electrical_j, hip_signed_mean_torque_nm and the
// same for the knee (J, N m; null: not measured).
struct ExportedLegEnergy {
  std::string leg;  // FL, L1, ...: the study's robot's name for it
  nlohmann::ordered_json values;
};

struct ExportedTrial {
  // Every column but the parameters, in the order the CSV writes them (nlohmann::ordered_json keeps it):
  // study_id, trial_id (0-based, the store's), rollout (1-based, the report's), state (done | in_flight),
  // phase, source (initial_design | model | validation), outcome, ok, fell, cost, J_* terms, feedback_*
  // fractions, torque, speed, distance, fall time, worker, attempt, faults, issued_at/reported_at (Unix s).
  nlohmann::ordered_json columns;
  std::map<std::string, double> params;  // the optimised parameters (the fixed ones are the study's)
  // One per leg the report measured, in the robot's leg order; none when the report has no energy (a rollout
  // that did not run, a store from before energy).
  std::vector<ExportedLegEnergy> leg_energy;
  // A hardware proposal's safety check (study::HardwareProposalRecord) as fall_probability,
  // within_fall_limit, cost_bound, cost_limit (null: none, the first rollout), within_cost_bound, basis;
  // null for every other trial and for hardware trials stored before the check.
  nlohmann::ordered_json hardware_proposal;
  bool done = false;
  bool ok = false;
  double cost = 0.0;
  double issued_at_s = 0.0;
  double reported_at_s = 0.0;
};

struct ExportedStudy {
  int study_id = 0;
  std::string name;
  std::string state;
  std::string message;
  double created_at_s = 0.0;
  std::string spec_sha256;
  std::vector<bo::Dimension> parameters;      // the search space, in its order
  std::vector<std::string> legs;              // the robot's legs by name, in its order (Morti's: FL FR HL HR)
  std::map<std::string, double> fixed;        // parameters held fixed by the study
  std::vector<ExportedTrial> trials;          // by trial_id: every trial the store holds (done and in flight)
};

// A stored report's energy per leg (its energy.joints.hip[i] and .knee[i], in the robot's leg order), each leg
// named by `legs`; none when the report has no energy. The one reading for exports and report.html.
std::vector<ExportedLegEnergy> leg_energy_of(const nlohmann::json& report, const std::vector<std::string>& legs);

// A per-leg column's name, as the CSV and the Optuna journal write it: leg_energy.L1.hip_positive_work_j.
std::string leg_energy_column(const std::string& leg, const std::string& key);

// Throws InputError for a study whose stored config cannot be read (it names the study).
ExportedStudy export_study(const study::StoredStudy& stored);

// CSV: a header, then one row per trial of every study; parameter columns are `params_<name>` (as Optuna's
// trials_dataframe names them), empty where a study has no such parameter; missing numbers are empty. Then the
// per-leg columns `leg_energy.<leg>.<key>` (leg_energy.L1.hip_positive_work_j), every leg of every study's
// robot, empty where a study has no such leg: last, so that every column before them keeps its place. After
// them, only when a trial has one, a hardware proposal's check as `hardware_proposal.<key>` (see
// ExportedTrial::hardware_proposal), empty for the other trials.
void write_csv(const std::vector<ExportedStudy>& studies, std::ostream& out);
// JSON: {"studies": [{study fields, "parameters": [...], "fixed": {...}, "legs": [...], "trials": [{columns...,
// "params": {...}, "leg_energy": {"<leg>": {...}, ...}}]}]}; a hardware proposal's trial also has
// "hardware_proposal": {...}.
// The CSV and Optuna journal name of a hardware proposal's key: hardware_proposal.cost_bound.
std::string hardware_proposal_column(const std::string& key);
nlohmann::ordered_json export_json(const std::vector<ExportedStudy>& studies);

}  // namespace cpgmatch::analysis
