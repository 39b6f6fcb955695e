// The reality-gap models (configs/model/*.yaml besides morti.yaml): each loads, differs from morti.yaml only
// where it says why, runs a 2-s rollout, and its robot measurably behaves as its physical cause says.
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

#include "cpgmatch/calibration/measured_trace.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/yaml_reader.hpp"
#include "../support/morti_legs.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch::calibration {
namespace {

const std::vector<std::string> kScenarios = {"worn-knee-spring", "battery-trunk", "stiff-gearbox", "slippery-belt",
                                             "late-foottiles"};

std::string model_path(const std::string& name) { return sim::config_dir() + "/model/" + name + ".yaml"; }

// Every entry's (value, source), keyed "section.key".
std::map<std::string, std::pair<double, std::string>> entries(const std::string& path) {
  const YamlReader r = YamlReader::from_file(path);
  std::map<std::string, std::pair<double, std::string>> out;
  for (const auto& section : r.node()) {
    for (const auto& entry : section.second) {
      out[section.first.as<std::string>() + "." + entry.first.as<std::string>()] = {
          entry.second["value"].as<double>(), entry.second["source"].as<std::string>()};
    }
  }
  return out;
}

struct ScenarioRun {
  RolloutResult result;
  MeasuredTrace trace;
  std::vector<PlantState> states;  // only for the foot forces and the height
};

ScenarioRun rollout(const std::string& model, double seconds = 2.0) {
  sim::SimRolloutJob job;
  job.params = load_parameters(sim::config_dir() + "/params/matched-trot.yaml");
  job.settings = load_rollout_settings(sim::default_rollout_settings_path());
  job.settings.entrain_s = seconds / 2;
  job.settings.eval_s = seconds / 2;
  job.model = sim::load_model_file(model_path(model));
  job.seed = 1;
  ScenarioRun run;
  const TraceSink record = record_trace(run.trace);
  run.result = sim::run_sim_rollout(job, [&](const TraceSample& s) {
    record(s);
    run.states.push_back(*s.state);
  });
  return run;
}

// While standing (0.2-0.4 s: the gait's amplitude is still ramping up from 0), averaged over the legs.
double standing_mean(const ScenarioRun& run, double (*of)(const PlantState&, int)) {
  double sum = 0.0;
  int n = 0;
  for (const PlantState& s : run.states) {
    if (s.time_s < 0.2 || s.time_s >= 0.4) continue;
    for (int leg = 0; leg < kNumLegs; ++leg, ++n) sum += of(s, leg);
  }
  return sum / n;
}
double knee_deflection(const ScenarioRun& run) {
  // Spring deflection = measured flexion minus the motor's commanded rest angle (0 while standing).
  double sum = 0.0;
  int n = 0;
  for (const MeasuredTick& t : run.trace.ticks) {
    if (t.time_s < 0.2 || t.time_s >= 0.4) continue;
    for (const auto& leg : t.legs) sum += leg.knee_rad - leg.knee_target_rad, ++n;
  }
  return sum / n;
}
double foot_force(const ScenarioRun& run) {
  return standing_mean(run, [](const PlantState& s, int leg) { return s.legs[leg].foot_normal_force_n; });
}

TEST(RealityGaps, EachDiffersFromMortiOnlyWhereItSaysWhy) {
  const auto base = entries(sim::default_model_path());
  for (const auto& name : kScenarios) {
    SCOPED_TRACE(name);
    const auto gap = entries(model_path(name));
    ASSERT_EQ(gap.size(), base.size());
    int changed = 0;
    for (const auto& [key, value_source] : gap) {
      ASSERT_TRUE(base.count(key)) << key;
      const bool differs = value_source.first != base.at(key).first;
      const bool says_why = value_source.second.rfind("REALITY GAP: ", 0) == 0;
      EXPECT_EQ(differs, says_why) << key << ": a changed value and only a changed one carries its cause";
      changed += differs;
    }
    EXPECT_GE(changed, 1);
  }
}

TEST(RealityGaps, EachLoadsAndRuns2s) {
  for (const auto& name : kScenarios) {
    SCOPED_TRACE(name);
    const ScenarioRun run = rollout(name);
    EXPECT_EQ(run.result.outcome, RolloutOutcome::kCompleted) << run.result.outcome_message;
    EXPECT_NEAR(run.result.sim_time_s, 2.0, 0.01);
  }
}

TEST(RealityGaps, PhysicsDiffersAsTheCauseSays) {
  const ScenarioRun morti = rollout("morti");
  const sim::PlanarLegModel base = sim::load_model_file(sim::default_model_path());
  {
    // 20% softer knee springs under the same standing load deflect 1/0.8 = 1.25 times as far.
    const ScenarioRun worn = rollout("worn-knee-spring");
    EXPECT_NEAR(knee_deflection(worn) / knee_deflection(morti), 1.25, 0.07);
  }
  {
    // The feet carry the whole robot: 0.5 kg more trunk raises every foot's load by the total mass's ratio.
    const ScenarioRun battery = rollout("battery-trunk");
    const double ratio = sim::load_model_file(model_path("battery-trunk")).total_mass_kg() / base.total_mass_kg();
    EXPECT_NEAR(foot_force(battery) / foot_force(morti), ratio, 0.03);
    EXPECT_GT(knee_deflection(battery), 1.08 * knee_deflection(morti));
  }
  {
    // A slower, more resistant hip follows its pattern less closely.
    const ScenarioRun stiff = rollout("stiff-gearbox");
    EXPECT_GT(stiff.result.hip_tracking_rms_rad, 1.1 * morti.result.hip_tracking_rms_rad);
  }
  {
    // Stance feet that slide push the body less far.
    const ScenarioRun slippery = rollout("slippery-belt");
    EXPECT_LT(slippery.result.breakdown.distance_m, 0.95 * morti.result.breakdown.distance_m);
  }
  {
    // The worn FootTile reports 70% of the force, and its softer dome lets the trunk sit lower by the
    // extra compression under a foot's load.
    const ScenarioRun late = rollout("late-foottiles");
    EXPECT_NEAR(foot_force(late) / foot_force(morti), 0.70, 0.02);
    const double load = foot_force(morti);
    const double extra_compression = load / 25000.0 - load / 50000.0;
    const double height_drop =
        standing_mean(morti, [](const PlantState& s, int) { return s.trunk.height_m; }) -
        standing_mean(late, [](const PlantState& s, int) { return s.trunk.height_m; });
    EXPECT_NEAR(height_drop, extra_compression, 0.5 * extra_compression);
  }
}

}  // namespace
}  // namespace cpgmatch::calibration
