// Simulation versus hardware for one study, as the paper's Supplementary Table 3: each cost term
// (eqs. 2-7) and the total cost, mean ± sd over the rollouts that ran on each kind of worker, beside the
// simulated optimum (the lowest-cost simulation rollout) and the paper's numbers. The hardware rollouts
// are normally a mixed study's validation sets; any rollout whose report says worker_kind hardware counts.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cpgmatch/analysis/trial.hpp"

namespace cpgmatch::analysis {

struct Sim2RealRow {
  std::string term;            // J_feedback, J_distance, J_pitch, J_contact, J_periodicity, total
  double sim_mean = 0.0, sim_sd = 0.0;
  double sim_best = 0.0;       // at the lowest-cost simulation rollout (the paper's "simulation" column)
  double hw_mean = 0.0, hw_sd = 0.0;
  std::string paper_sim, paper_hw;  // the paper's values as printed ("" where it gives none)
};

struct Sim2RealTable {
  std::string study_name;
  int study_id = 0;
  int sim_rollouts = 0;        // ran (ok) on simulation workers
  int hw_rollouts = 0;         // ran (ok) on hardware workers
  int sim_best_trial = -1;     // trial id of the lowest-cost simulation rollout (-1: none)
  std::vector<Sim2RealRow> rows;
};

// The study's exploration as the science report should see it: without the hardware rollouts when it
// also has simulation ones (a mixed study's validation sets measure the answer, they are not part of the
// search). A study without simulation rollouts (hardware-only) is returned whole.
StudyTrials exploration_trials(const StudyTrials& study);

// NaN where a side has no rollout (sd: fewer than two).
Sim2RealTable sim2real_table(const StudyTrials& study);
nlohmann::json sim2real_json(const Sim2RealTable& table);
// Aligned text for a terminal and the study report.
std::string sim2real_text(const Sim2RealTable& table);
// sim2real.png/.svg in out_dir: every cost term per rollout, simulation rollouts as lines, hardware
// rollouts as dots of the same colour over them (the paper's Fig. 5b with the hardware sets). Throws PlotError.
std::vector<std::filesystem::path> plot_sim2real(const StudyTrials& study, const std::filesystem::path& out_dir);

}  // namespace cpgmatch::analysis
