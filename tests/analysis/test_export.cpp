// `cpgmatch export` from a study store made through the store's API: one row per trial, whatever its state
// (done, failed, fell, still in flight), in CSV, JSON and as an Optuna journal whose lines replay as Optuna
// replays them. (tests/cli/test_export_optuna.sh loads a real study's journal in Optuna itself.)
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <sstream>

#include "cpgmatch/analysis/optuna_journal.hpp"
#include "cpgmatch/analysis/stored_study_trials.hpp"
#include "cpgmatch/analysis/study_export.hpp"
#include "cpgmatch/study/study_spec.hpp"
#include "cpgmatch/study/study_store.hpp"

namespace cpgmatch::analysis {
namespace {

namespace fs = std::filesystem;

domain::RolloutReport report(int study, int trial, bool fell, double cost) {
  domain::RolloutReport r;
  r.id.study_id = study;
  r.id.trial_id = trial;
  r.worker_id = "node-" + std::to_string(trial);
  r.outcome = fell ? domain::Outcome::kFell : domain::Outcome::kCompleted;
  r.summary.cost = cost;
  r.summary.fall_time_s = fell ? 12.5 : -1.0;
  r.summary.normalized_torque = 30.0;
  r.summary.mean_speed_mps = 0.3;
  r.summary.feedback = FeedbackFractions{0.1, 0.2, 0.3, 0.4};
  r.summary.terms = CostTerms{0.2, 0.3, 0.1, 0.0, 0.01};
  return r;
}

domain::RolloutReport crashed(int study, int trial) {
  domain::RolloutReport r;
  r.id.study_id = study;
  r.id.trial_id = trial;
  r.worker_id = "node-" + std::to_string(trial);
  r.outcome = domain::Outcome::kError;
  r.error = "rollout crashed, \"badly\"";
  return r;
}

class ExportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("export-" + std::to_string(getpid()));
    fs::create_directories(dir_);
    store_path_ = (dir_ / "s.db").string();
    study::StudyStore store(store_path_);
    // Two studies of the same name (Optuna needs unique names); the first with 5 trials: walked, fell,
    // failed, walked, and one still in flight.
    for (int k = 0; k < 2; ++k) {
      const int id = store.create_study("gait", "name: gait\nbudget: 5\ninitial_points: 2\n", "s.yaml", 1.7e9 + k);
      std::vector<study::StoredTrial> trials;
      for (int i = 0; i < (k == 0 ? 5 : 1); ++i) {
        study::StoredTrial t;
        t.trial_id = i;
        t.x = Eigen::VectorXd::Constant(6, 0.1 + 0.05 * i);
        t.x[1] = 0.5;
        t.worker_id = "node-" + std::to_string(i);
        t.issued_at_s = 1.7e9 + 10 * i;
        trials.push_back(t);
      }
      store.add_trials(id, trials);
      if (k == 1) continue;
      store.complete_trial(report(id, 0, false, 2.5), 1.7e9 + 5);
      store.complete_trial(report(id, 1, true, 17.0), 1.7e9 + 15);
      store.complete_trial(crashed(id, 2), 1.7e9 + 25);
      store.complete_trial(report(id, 3, false, 0.9), 1.7e9 + 35);
    }
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::vector<ExportedStudy> all() const {
    std::vector<ExportedStudy> out;
    for (const auto& s : study::StudyStore(store_path_).load_all()) out.push_back(export_study(s));
    return out;
  }
  fs::path dir_;
  std::string store_path_;
};

TEST_F(ExportTest, OneRowPerStoredTrialWithHowItEnded) {
  const auto studies = all();
  ASSERT_EQ(studies.size(), 2u);
  const ExportedStudy& s = studies[0];
  ASSERT_EQ(s.trials.size(), 5u);
  ASSERT_EQ(s.parameters.size(), 6u);  // the paper's space: no parameters in the study file
  const auto& c = s.trials;
  EXPECT_EQ(c[0].columns["source"], "initial_design");
  EXPECT_EQ(c[2].columns["source"], "model");
  EXPECT_EQ(c[0].columns["outcome"], "completed");
  EXPECT_EQ(c[1].columns["outcome"], "fell");
  EXPECT_EQ(c[1].columns["fell"], true);
  EXPECT_EQ(c[1].columns["fall_time_s"], 12.5);
  EXPECT_TRUE(c[0].columns["fall_time_s"].is_null()) << "a rollout that walked has no fall time";
  EXPECT_EQ(c[2].columns["outcome"], "error");
  EXPECT_EQ(c[2].columns["ok"], false);
  EXPECT_TRUE(c[2].columns["cost"].is_null());
  EXPECT_EQ(c[4].columns["state"], "in_flight");
  EXPECT_EQ(c[4].columns["outcome"], "");
  EXPECT_EQ(c[3].columns["J_feedback"], 0.2);
  EXPECT_EQ(c[3].columns["feedback_early_toeoff"], 0.3);
  EXPECT_EQ(c[3].columns["worker_id"], "node-3");
  EXPECT_DOUBLE_EQ(c[3].params.at("hip_amplitude"), 0.5);
}

TEST_F(ExportTest, CsvHasAHeaderAndOneLinePerTrialWithQuotedText) {
  std::ostringstream out;
  write_csv(all(), out);
  std::vector<std::string> lines;
  std::istringstream in(out.str());
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  ASSERT_EQ(lines.size(), 1u + 5u + 1u);
  EXPECT_EQ(lines[0].rfind("study_id,study_name,trial_id,rollout,state,", 0), 0u) << lines[0];
  EXPECT_NE(lines[0].find(",params_hip_offset,"), std::string::npos);
  EXPECT_NE(lines[3].find("\"rollout crashed, \"\"badly\"\"\""), std::string::npos) << lines[3];
  EXPECT_NE(lines[1].find(",2.5,"), std::string::npos) << lines[1];
}

TEST_F(ExportTest, OptunaJournalReplaysToTheStoredTrials) {
  std::ostringstream out;
  const auto names = write_optuna_journal(all(), out);
  ASSERT_EQ(names.size(), 2u);
  EXPECT_EQ(names[0], "gait (study 1)");
  EXPECT_EQ(names[1], "gait (study 2)");
  std::istringstream in(out.str());
  int studies = 0;
  std::vector<nlohmann::json> trials;
  for (std::string l; std::getline(in, l);) {
    const auto j = nlohmann::json::parse(l);
    ASSERT_TRUE(j.contains("worker_id"));
    if (j["op_code"] == 0) {
      ++studies;
      EXPECT_EQ(j["directions"], nlohmann::json::array({1}));
    }
    if (j["op_code"] == 4) trials.push_back(j);
  }
  EXPECT_EQ(studies, 2);
  ASSERT_EQ(trials.size(), 6u);
  EXPECT_EQ(trials[0]["state"], 1);  // COMPLETE
  EXPECT_EQ(trials[0]["value"], 2.5);
  EXPECT_EQ(trials[1]["state"], 1);  // a fall is a measured cost
  EXPECT_EQ(trials[1]["user_attrs"]["fell"], true);
  EXPECT_EQ(trials[2]["state"], 3);  // FAIL
  EXPECT_TRUE(trials[2]["value"].is_null());
  EXPECT_EQ(trials[4]["state"], 0);  // RUNNING: no completion time
  EXPECT_FALSE(trials[4].contains("datetime_complete"));
  EXPECT_TRUE(trials[0].contains("datetime_complete"));
  EXPECT_EQ(trials[5]["study_id"], 1);
  // Distributions are JSON strings inside the line, as optuna.distributions.distribution_to_json writes them.
  const auto d = nlohmann::json::parse(trials[0]["distributions"]["hip_offset"].get<std::string>());
  EXPECT_EQ(d["name"], "FloatDistribution");
  EXPECT_EQ(d["attributes"]["log"], false);
  EXPECT_TRUE(trials[0]["params"]["hip_offset"].is_number());
  EXPECT_EQ(trials[0]["params"].size(), 6u);
}

TEST_F(ExportTest, JsonNestsTrialsUnderTheirStudy) {
  const auto j = export_json(all());
  ASSERT_EQ(j["studies"].size(), 2u);
  EXPECT_EQ(j["studies"][0]["trials"].size(), 5u);
  EXPECT_EQ(j["studies"][0]["fixed"]["frequency"], 1.0);
  EXPECT_EQ(j["studies"][0]["trials"][3]["params"].size(), 6u);
}

// Every leg of a robot with `legs` legs: the hip's positive work 10 + leg J, the knee's 20 + leg J.
domain::RolloutReport walked_with_energy(int study, int trial, std::size_t legs) {
  domain::RolloutReport r = report(study, trial, false, 1.5);
  r.summary.energy.hip = PerLeg<JointEnergy>(legs);
  r.summary.energy.knee = PerLeg<JointEnergy>(legs);
  for (std::size_t leg = 0; leg < legs; ++leg) {
    r.summary.energy.hip[leg] = JointEnergy{10.0 + leg, 1.0, 11.0 + leg, 0.5};
    r.summary.energy.knee[leg] = JointEnergy{20.0 + leg, 2.0, 22.0 + leg, -0.5};
  }
  return r;
}

std::vector<std::string> csv_lines(const std::vector<ExportedStudy>& studies) {
  std::ostringstream out;
  write_csv(studies, out);
  std::vector<std::string> lines;
  std::istringstream in(out.str());
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

// One column of a CSV line (no quoted commas in the lines these tests read).
std::vector<std::string> cells(const std::string& line) {
  std::vector<std::string> out;
  std::istringstream in(line);
  for (std::string cell; std::getline(in, cell, ',');) out.push_back(cell);
  if (!line.empty() && line.back() == ',') out.push_back("");
  return out;
}

class RobotExportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("export-robot-" + std::to_string(getpid()));
    fs::create_directories(dir_);
    store_path_ = (dir_ / "s.db").string();
  }
  void TearDown() override { fs::remove_all(dir_); }
  // A study as the service stores it: its resolved spec beside the text, one trial that walked.
  ExportedStudy stored_robot_study(const std::string& yaml, std::size_t legs) {
    const auto spec = study::StudySpec::resolve(yaml, "s.yaml", study::SpecDefaults::shipped());
    study::StudyStore store(store_path_);
    const int id = store.create_study(spec.config().name, yaml, "s.yaml", 1.7e9,
                                      study::StoredSpec{spec.canonical_json(), spec.sha256(), study::kOriginSubmitted});
    study::StoredTrial t;
    t.trial_id = 0;
    t.x = Eigen::VectorXd::Constant(static_cast<int>(spec.config().space.dimensions().size()), 0.3);
    store.add_trials(id, {t});
    store.complete_trial(walked_with_energy(id, 0, legs), 1.7e9 + 5);
    return export_study(store.load_all().back());
  }
  fs::path dir_;
  std::string store_path_;
};

TEST_F(RobotExportTest, AHexapodsColumnsNameItsSixLegsAndItsOwnParameters) {
  const ExportedStudy s = stored_robot_study("name: hex\nbudget: 4\ninitial_points: 2\nrobot: moteus-hexapod\n", 6);
  EXPECT_EQ(s.legs, (std::vector<std::string>{"L1", "R1", "L2", "R2", "L3", "R3"}));
  const auto lines = csv_lines({s});
  ASSERT_EQ(lines.size(), 2u);
  const auto header = cells(lines[0]);
  const auto row = cells(lines[1]);
  ASSERT_EQ(header.size(), row.size()) << lines[0] << "\n" << lines[1];
  std::map<std::string, std::string> value;
  for (std::size_t i = 0; i < header.size(); ++i) value[header[i]] = row[i];
  // Each leg's values under its own name, in the robot's order (L3 is the fifth leg).
  EXPECT_EQ(value.at("leg_energy.L1.hip_positive_work_j"), "10");
  EXPECT_EQ(value.at("leg_energy.L3.hip_positive_work_j"), "14");
  EXPECT_EQ(value.at("leg_energy.R3.knee_electrical_j"), "27");
  EXPECT_EQ(value.at("leg_energy.R3.knee_signed_mean_torque_nm"), "-0.5");
  int leg_columns = 0;
  for (const auto& h : header) leg_columns += h.rfind("leg_energy.", 0) == 0;
  EXPECT_EQ(leg_columns, 6 * 8);
  for (const char* morti : {"FL", "FR", "HL", "HR"}) {
    EXPECT_EQ(lines[0].find(fmt::format(".{}.", morti)), std::string::npos) << "a Morti leg in: " << lines[0];
  }
  // The robot's own search space: its parameters, and no knee_amplitude or frequency (its preset fixes them).
  std::vector<std::string> params;
  for (const auto& h : header) if (h.rfind("params_", 0) == 0) params.push_back(h.substr(7));
  std::vector<std::string> space;
  for (const auto& d : s.parameters) space.push_back(d.name);
  EXPECT_EQ(params, space);
  EXPECT_EQ(value.count("params_frequency"), 0u);
  EXPECT_EQ(s.fixed.at("frequency"), 1.5);

  const auto j = export_json({s});
  EXPECT_EQ(j["studies"][0]["legs"], nlohmann::json({"L1", "R1", "L2", "R2", "L3", "R3"}));
  EXPECT_EQ(j["studies"][0]["trials"][0]["leg_energy"]["R2"]["hip_positive_work_j"], 13.0);
  EXPECT_EQ(j["studies"][0]["parameters"][1]["unit"], "rad");  // hip_amplitude, as the robot.yaml says

  std::ostringstream journal;
  write_optuna_journal({s}, journal);
  EXPECT_NE(journal.str().find("\"leg_energy.R3.knee_positive_work_j\":25"), std::string::npos);
  EXPECT_EQ(journal.str().find("leg_energy.FL."), std::string::npos);
}

// A store from before robots: no spec, Morti's four legs in the reports. Every column it exported before the
// per-leg columns existed is still there, in the same place, and the per-leg columns after them name Morti's legs.
TEST_F(RobotExportTest, AnOldFourLegStoreExportsTheColumnsItDidThenMortisLegs) {
  {
    study::StudyStore store(store_path_);
    const int id = store.create_study("old", "name: old\nbudget: 2\ninitial_points: 1\n", "old.yaml", 1.6e9);
    study::StoredTrial t;
    t.trial_id = 0;
    t.x = Eigen::VectorXd::Constant(6, 0.2);
    store.add_trials(id, {t});
    store.complete_trial(walked_with_energy(id, 0, 4), 1.6e9 + 5);
  }
  const auto stored = study::StudyStore(store_path_).load_all();
  ASSERT_TRUE(stored.at(0).spec.json.empty());
  const ExportedStudy s = export_study(stored.at(0));
  EXPECT_EQ(s.legs, (std::vector<std::string>{"FL", "FR", "HL", "HR"}));
  const auto lines = csv_lines({s});
  ASSERT_EQ(lines.size(), 2u);
  // The header `cpgmatch export` wrote for this store before per-leg columns (main at 2496198).
  const std::string before =
      "study_id,study_name,trial_id,rollout,state,phase,source,outcome,ok,fell,cost,J_feedback,J_distance,J_pitch,"
      "J_contact,J_periodicity,feedback_late_touchdown,feedback_early_touchdown,feedback_early_toeoff,"
      "feedback_late_toeoff,normalized_torque,summed_torque_nm,mean_speed_mps,distance_m,fall_time_s,worker_id,"
      "worker_kind,synthetic,attempt,faults,issued_at,reported_at,wall_time_s,error,params_hip_offset,"
      "params_hip_amplitude,params_duty_factor_front,params_duty_factor_hind,params_knee_phase_shift,params_overswing";
  ASSERT_EQ(lines[0].rfind(before + ",", 0), 0u) << lines[0];
  const auto legs = cells(lines[0].substr(before.size() + 1));
  ASSERT_EQ(legs.size(), 4u * 8u);
  EXPECT_EQ(legs.front(), "leg_energy.FL.hip_positive_work_j");
  EXPECT_EQ(legs.back(), "leg_energy.HR.knee_signed_mean_torque_nm");
  const auto row = cells(lines[1]);
  ASSERT_EQ(row.size(), cells(before).size() + legs.size());
  EXPECT_EQ(row[cells(before).size() + 3 * 8], "13") << "HR's hip";
}

// A transfer study's hardware proposals keep their safety check (issue 33): exported after every other column
// (each earlier one in its place), in the JSON under each hardware trial, as Optuna user attributes; the
// exploration trials leave them empty.
TEST_F(ExportTest, AHardwareProposalsSafetyCheckIsExportedLastAndOnlyWhereThereIsOne) {
  std::string header_before;
  {
    const auto before = csv_lines(all());
    header_before = before.at(0);
  }
  {
    study::StudyStore store(store_path_);
    study::StoredTrial first, later;
    first.trial_id = 5;
    first.x = Eigen::VectorXd::Constant(6, 0.3);
    first.phase = "hardware";
    first.proposal = study::HardwareProposalRecord{0.05, true, 1.2, std::nullopt, true, "simulation_optimum"};
    later = first;
    later.trial_id = 6;
    later.proposal = study::HardwareProposalRecord{0.15, true, 1.4, 1.32, false, "lowest_bound"};
    store.add_trials(1, {first, later});
  }
  const auto studies = all();
  const auto& trials = studies.at(0).trials;
  ASSERT_EQ(trials.size(), 7u);
  EXPECT_TRUE(trials[0].hardware_proposal.is_null());
  EXPECT_EQ(trials[6].hardware_proposal["cost_limit"], 1.32);
  EXPECT_TRUE(trials[5].hardware_proposal["cost_limit"].is_null());
  const auto lines = csv_lines(studies);
  ASSERT_EQ(lines[0].rfind(header_before + ",", 0), 0u) << lines[0];
  EXPECT_EQ(lines[0].substr(header_before.size()),
            ",hardware_proposal.fall_probability,hardware_proposal.within_fall_limit,hardware_proposal.cost_bound,"
            "hardware_proposal.cost_limit,hardware_proposal.within_cost_bound,hardware_proposal.basis");
  const auto header = cells(lines[0]);
  for (std::size_t i = 1; i < lines.size(); ++i) {
    // (cells() splits at every comma: the crashed trial's quoted error has one)
    if (lines[i].find('"') == std::string::npos) {
      ASSERT_EQ(cells(lines[i]).size(), header.size()) << lines[i];
    }
  }
  auto value = [&](std::size_t line, const std::string& column) {
    const auto row = cells(lines.at(line));
    return row.at(static_cast<std::size_t>(std::find(header.begin(), header.end(), column) - header.begin()));
  };
  EXPECT_EQ(value(1, "hardware_proposal.basis"), "");
  EXPECT_EQ(value(6, "hardware_proposal.basis"), "simulation_optimum");
  EXPECT_EQ(value(6, "hardware_proposal.cost_limit"), "");
  EXPECT_EQ(value(7, "hardware_proposal.cost_limit"), "1.32");
  EXPECT_EQ(value(7, "hardware_proposal.within_cost_bound"), "false");
  const auto json = export_json(studies);
  const auto& rows = json["studies"][0]["trials"];
  EXPECT_FALSE(rows[0].contains("hardware_proposal"));
  EXPECT_EQ(rows[6]["hardware_proposal"]["basis"], "lowest_bound");
  std::ostringstream journal;
  write_optuna_journal(studies, journal);
  EXPECT_NE(journal.str().find("\"hardware_proposal.basis\":\"lowest_bound\""), std::string::npos);
}

}  // namespace
}  // namespace cpgmatch::analysis
