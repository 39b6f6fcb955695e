// A study spec owns its objective: resolved by content from a study file's overrides and the defaults,
// hashed, and written back as a study file that resolves to the same hash.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/study/spec_rollout.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::study {
namespace {

const SpecDefaults kShipped = SpecDefaults::shipped();

TEST(StudySpec, ANameAloneResolvesToTheShippedModelSettingsAndParameters) {
  const StudySpec spec = StudySpec::resolve("name: plain\n", "plain.yaml", kShipped);
  const sim::PlanarLegModel shipped_model = sim::load_model_file(kShipped.model_path);
  EXPECT_EQ(spec.model().knee_spring.stiffness_nm_per_rad, shipped_model.knee_spring.stiffness_nm_per_rad);
  EXPECT_EQ(spec.model().trunk_mass_kg, shipped_model.trunk_mass_kg);
  const RolloutSettings shipped_settings = load_rollout_settings(kShipped.rollout_settings_path);
  EXPECT_EQ(spec.rollout_settings().cost.weights.feedback, shipped_settings.cost.weights.feedback);
  EXPECT_EQ(spec.rollout_settings().controller.gait, shipped_settings.controller.gait);
  EXPECT_EQ(to_map(spec.base_parameters()), to_map(load_parameters(kShipped.base_parameters_path)));
  // Every CPG parameter has a value in the spec itself (no worker default can fill a gap).
  EXPECT_EQ(spec.tree()["base_parameters"].size(), to_map(CpgParameters{}).size());
  EXPECT_EQ(spec.objective_version(), kObjectiveVersion);
  EXPECT_EQ(spec.sha256().size(), 64u);
  EXPECT_EQ(spec_key_hex(spec.key()), spec.sha256().substr(0, 16));
}

TEST(StudySpec, OverridesChangeOnlyTheirValuesAndSaySoInTheSource) {
  const StudySpec plain = StudySpec::resolve("name: s\n", "s.yaml", kShipped);
  const StudySpec stiff = StudySpec::resolve(
      "name: s\nmodel: {knee_spring: {stiffness_nm_per_rad: 20}}\n"
      "rollout_settings: {cost: {weights: {feedback: 4}}, controller: {feedback: {early_toeoff: false}}}\n"
      "base_parameters: {frequency: 1.2}\n",
      "s.yaml", kShipped);
  EXPECT_EQ(stiff.model().knee_spring.stiffness_nm_per_rad, 20.0);
  EXPECT_EQ(stiff.model().knee_spring.damping_nm_s_per_rad, plain.model().knee_spring.damping_nm_s_per_rad);
  EXPECT_EQ(stiff.tree()["model"]["knee_spring"]["stiffness_nm_per_rad"]["source"], "study override");
  EXPECT_EQ(stiff.rollout_settings().cost.weights.feedback, 4.0);
  EXPECT_FALSE(stiff.rollout_settings().controller.feedback.early_toeoff);
  EXPECT_EQ(stiff.base_parameters().frequency, 1.2);
  EXPECT_NE(stiff.sha256(), plain.sha256());
}

TEST(StudySpec, TheSameExperimentWrittenTwoWaysHasOneHash) {
  const StudySpec a = StudySpec::resolve("name: s\nmodel: {knee_spring: {stiffness_nm_per_rad: 20}}\n", "a.yaml", kShipped);
  const StudySpec b = StudySpec::resolve("name: s\nmodel:\n  knee_spring:\n    stiffness_nm_per_rad: 20.0\n", "b.yaml", kShipped);
  EXPECT_EQ(a.sha256(), b.sha256());
}

TEST(StudySpec, ItsStudyFileResubmitsToTheSameHashAndTheSameValuesToTheBit) {
  const StudySpec spec = StudySpec::resolve(
      "name: show-me\nbudget: 12\ninitial_points: 4\nseed: 7\nterrain: rough:0.003\nrollout: {entrain_s: 2.5, eval_s: 3}\n"
      "model: {contact: {friction: 0.7000000000000001}}\nbase_parameters: {hip_offset: -0.1}\n",
      "show.yaml", kShipped);
  const std::string file = spec.to_study_yaml();
  const StudySpec again = StudySpec::resolve(file, "shown.yaml", kShipped);
  EXPECT_EQ(again.sha256(), spec.sha256()) << file;
  EXPECT_EQ(again.model().contact.friction, 0.7000000000000001);
  EXPECT_EQ(again.config().budget, 12);
  EXPECT_EQ(again.config().terrain, "rough:0.003");
  // And from its canonical JSON (the store, the wire).
  EXPECT_EQ(StudySpec::from_json_text(spec.canonical_json(), "stored").sha256(), spec.sha256());
}

TEST(StudySpec, StudyKeysAreCanonicalAndTextStaysText) {
  const StudySpec a = StudySpec::resolve("name: s\nbudget: 12\ninitial_points: 4\nrollout: {eval_s: 3}\n", "a", kShipped);
  const StudySpec b = StudySpec::resolve("name: s\nbudget: 12.0\ninitial_points: 4\nrollout: {eval_s: 3.0}\n", "b", kShipped);
  EXPECT_EQ(a.sha256(), b.sha256());
  const StudySpec text = StudySpec::resolve("name: 1.10\nterrain: flat\n", "t", kShipped);
  EXPECT_EQ(text.config().name, "1.10");
  EXPECT_EQ(text.tree()["study"]["name"], "1.10");
  EXPECT_EQ(StudySpec::resolve(text.to_study_yaml(), "again", kShipped).sha256(), text.sha256());
}

TEST(StudySpec, AnOverriddenValuesSourceStaysHonest) {
  const StudySpec plain = StudySpec::resolve("name: s\n", "s", kShipped);
  const auto& knee = plain.tree()["model"]["knee_spring"]["stiffness_nm_per_rad"];
  // The default's own value: the same experiment, the same source and hash.
  const StudySpec same = StudySpec::resolve(
      fmt::format("name: s\nmodel: {{knee_spring: {{stiffness_nm_per_rad: {}}}}}\n", knee["value"].get<double>()), "s",
      kShipped);
  EXPECT_EQ(same.sha256(), plain.sha256());
  // A new value in the mapping form without a source: "study override", not the default's source.
  const StudySpec mapped =
      StudySpec::resolve("name: s\nmodel: {knee_spring: {stiffness_nm_per_rad: {value: 20}}}\n", "s", kShipped);
  EXPECT_EQ(mapped.tree()["model"]["knee_spring"]["stiffness_nm_per_rad"]["source"], "study override");
  const StudySpec sourced = StudySpec::resolve(
      "name: s\nmodel: {knee_spring: {stiffness_nm_per_rad: {value: 20, source: measured 2026-11}}}\n", "s", kShipped);
  EXPECT_EQ(sourced.tree()["model"]["knee_spring"]["stiffness_nm_per_rad"]["source"], "measured 2026-11");
  EXPECT_THROW((void)StudySpec::resolve("name: s\nmodel: {knee_spring: {stiffness_nm_per_rad: {source: x}}}\n", "s",
                                        kShipped),
               InputError);
}

TEST(StudySpec, ASpecNestedTooDeeplyIsRefusedNotRecursedInto) {
  const std::string deep = std::string(20000, '[') + std::string(20000, ']');
  EXPECT_THROW((void)StudySpec::from_json_text(deep, "deep"), InputError);
}

TEST(StudySpec, AnotherObjectiveVersionIsAnotherSpec) {
  const StudySpec now = StudySpec::resolve("name: s\n", "s.yaml", kShipped);
  const StudySpec other = StudySpec::resolve("name: s\n", "s.yaml", kShipped, kObjectiveVersion + 1);
  EXPECT_NE(now.sha256(), other.sha256());
  EXPECT_EQ(other.objective_version(), kObjectiveVersion + 1);
}

void expect_refused(const std::string& yaml, const std::string& needle) {
  try {
    (void)StudySpec::resolve(yaml, "bad.yaml", kShipped);
    ADD_FAILURE() << "accepted: " << yaml;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(StudySpec, BadOverridesAreRefusedNamingFileLineAndField) {
  expect_refused("name: s\nmodel:\n  knee_sprng: {stiffness_nm_per_rad: 20}\n", "bad.yaml:3: field 'model.knee_sprng'");
  expect_refused("name: s\nmodel: {knee_spring: {stiffness_nm_per_rad: stiff}}\n", "is not a number");
  expect_refused("name: s\nmodel: {knee_spring: {stiffness_nm_per_rad: -3}}\n", "must be > 0");
  expect_refused("name: s\nrollout_settings: {cost: {weights: 3}}\n", "is a mapping here");
  expect_refused("name: s\nrollout_settings: {entrain_s: 3}\n", "rollout_settings.entrain_s");
  expect_refused("name: s\nbase_parameters: {frequency: 99}\n", "frequency");
  expect_refused("name: s\nrollout_settings: {controller: {gait: gallop}}\n", "gait");
}

TEST(StudySpec, ATamperedTreeDoesNotLoad) {
  const StudySpec spec = StudySpec::resolve("name: s\n", "s.yaml", kShipped);
  nlohmann::json tree = spec.tree();
  tree.erase("model");
  EXPECT_THROW((void)StudySpec::from_json_text(tree.dump(), "t"), InputError);
  EXPECT_THROW((void)StudySpec::from_json_text("{not json", "t"), InputError);
}

TEST(StudySpec, ATrialsRolloutIsSetUpFromTheSpecAlone) {
  const StudySpec spec = StudySpec::resolve(
      "name: s\nseed: 4\nmodel: {knee_spring: {stiffness_nm_per_rad: 9}}\nbase_parameters: {overswing: 0.05}\n", "s.yaml",
      kShipped);
  const sim::SimRolloutJob job = sim_job_for(spec, {{"hip_offset", 0.1}}, "flat", trial_seed(spec, 3), 1.0, 2.0);
  EXPECT_EQ(job.model.knee_spring.stiffness_nm_per_rad, 9.0);
  EXPECT_EQ(job.params.hip_offset, 0.1);
  EXPECT_EQ(job.params.overswing, 0.05);
  EXPECT_EQ(job.settings.entrain_s, 1.0);
  EXPECT_EQ(job.settings.eval_s, 2.0);
  EXPECT_EQ(trial_seed(spec, 3), trial_seed(spec, 3));
  EXPECT_NE(trial_seed(spec, 3), trial_seed(spec, 4));
}

}  // namespace
}  // namespace cpgmatch::study
