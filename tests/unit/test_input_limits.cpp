// Bad input is refused at the door with the field (and file:line) named: study files, YAML keys, names.
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/rollout.hpp"
#include "cpgmatch/study/study_config.hpp"
#include "cpgmatch/text.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch {
namespace {

// The message of the InputError a study file raises ("" when it loads).
std::string study_error(const std::string& yaml) {
  try {
    (void)study::load_study_config_text(yaml, "s.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(InputLimits, TheFileThatCrashedTheServiceIsRefusedNamingTheField) {
  const std::string e = study_error("name: a\ninitial_points: 2000000000\n");
  EXPECT_NE(e.find("s.yaml:2"), std::string::npos) << e;
  EXPECT_NE(e.find("initial_points"), std::string::npos) << e;
}

TEST(InputLimits, EveryNumericStudyKeyHasARange) {
  EXPECT_NE(study_error("name: a\nbudget: 1000000\n").find("budget"), std::string::npos);
  EXPECT_NE(study_error("name: a\nbudget: 0\n").find("budget"), std::string::npos);
  EXPECT_NE(study_error("name: a\nbudget: 10\ninitial_points: 11\n").find("initial_points"), std::string::npos);
  EXPECT_NE(study_error("name: a\nseed: -1\n").find("seed"), std::string::npos);
  EXPECT_NE(study_error("name: a\nrollout: {eval_s: .nan}\n").find("eval_s"), std::string::npos);
  EXPECT_NE(study_error("name: a\nrollout: {entrain_s: 1e12}\n").find("entrain_s"), std::string::npos);
  EXPECT_NE(study_error("name: a\nlease_s: 1e9\n").find("lease_s"), std::string::npos);
  EXPECT_EQ(study_error("name: a\nbudget: 20\ninitial_points: 20\n"), "");  // the edges are allowed
}

TEST(InputLimits, OptimizerChoicesAreNamedWithTheirLine) {
  const std::string transform = study_error("name: a\ncost_transform: sqrt\n");
  EXPECT_NE(transform.find("s.yaml:2"), std::string::npos) << transform;
  EXPECT_NE(transform.find("cost_transform"), std::string::npos) << transform;
  EXPECT_NE(transform.find("known: none, log"), std::string::npos) << transform;
  const std::string liar = study_error("name: a\nliar: optimist\n");
  EXPECT_NE(liar.find("liar"), std::string::npos) << liar;
  EXPECT_EQ(study_error("name: a\ncost_transform: log\nliar: believer\n"), "");
}

TEST(InputLimits, StudyNamesAreBoundedPrintableUtf8) {
  EXPECT_NE(study_error("name: a\xff\xfe\n").find("name"), std::string::npos);  // raw bytes, not UTF-8
  EXPECT_NE(study_error("name: " + std::string(65, 'x') + "\n").find("at most 64"), std::string::npos);
  EXPECT_NE(study_error("name: \"a\\tb\"\n").find("control"), std::string::npos);
  EXPECT_EQ(study_error("name: Lauf über Kopfsteinpflaster\n"), "");
}

TEST(InputLimits, DuplicateAndNonScalarKeysAreRefusedWithTheirLine) {
  const std::string dup = study_error("name: a\nbudget: 10\nbudget: 20\n");
  EXPECT_NE(dup.find("s.yaml:3"), std::string::npos) << dup;
  EXPECT_NE(dup.find("duplicate"), std::string::npos) << dup;
  const std::string nonscalar = study_error("name: a\n[1, 2]: 3\n");
  EXPECT_NE(nonscalar.find("s.yaml:2"), std::string::npos) << nonscalar;
  EXPECT_NE(nonscalar.find("plain names"), std::string::npos) << nonscalar;
}

// The message of the InputError a rollout settings file raises ("" when it loads).
std::string settings_error(const std::string& yaml) {
  const std::string path = ::testing::TempDir() + "/settings.yaml";
  std::ofstream(path) << yaml;
  try {
    (void)load_rollout_settings(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(InputLimits, EveryNumberInTheRolloutSettingsHasARange) {
  // Each of these used to load: a 1e9-s reflex lasts the whole rollout, a 1e12-Hz controller was refused
  // only once a rollout started, and a negative cost weight rewards the very thing its term penalises.
  const struct {
    const char* yaml;
    const char* field;
  } bad[] = {
      {"entrain_s: 1.0e12\n", "entrain_s"},
      {"controller: {control_rate_hz: 1.0e12}\n", "control_rate_hz"},
      {"controller: {startup_ramp_s: -1}\n", "startup_ramp_s"},
      {"controller: {feedback: {reflex_duration_s: 1.0e9}}\n", "reflex_duration_s"},
      {"controller: {feedback: {reflex_knee_flexion_rad: 100}}\n", "reflex_knee_flexion_rad"},
      {"controller: {feedback: {late_toeoff_phase_rate: 2}}\n", "late_toeoff_phase_rate"},
      {"cost: {weights: {pitch: -1}}\n", "pitch"},
      {"cost: {fall_max_abs_pitch_rad: 7}\n", "fall_max_abs_pitch_rad"},
      {"cost: {fall_cost_per_lost_fraction: -5}\n", "fall_cost_per_lost_fraction"},
      {"cost: {min_distance_m: 0}\n", "min_distance_m"},
  };
  for (const auto& b : bad) {
    const std::string e = settings_error(b.yaml);
    EXPECT_NE(e.find(b.field), std::string::npos) << b.yaml << " -> " << e;
    EXPECT_NE(e.find("settings.yaml:1"), std::string::npos) << e;
  }
  EXPECT_EQ(settings_error("controller: {feedback: {reflex_duration_s: 1.0, reflex_knee_flexion_rad: 0}}\n"), "");
}

TEST(Text, Utf8Validation) {
  EXPECT_TRUE(is_valid_utf8("plain"));
  EXPECT_TRUE(is_valid_utf8("\xc3\xbc\xe2\x82\xac\xf0\x9f\x90\x95"));  // ü € dog
  EXPECT_FALSE(is_valid_utf8("\xc3"));               // truncated
  EXPECT_FALSE(is_valid_utf8("\xc0\xaf"));           // overlong '/'
  EXPECT_FALSE(is_valid_utf8("\xed\xa0\x80"));       // a surrogate
  EXPECT_FALSE(is_valid_utf8("\xf4\x90\x80\x80"));   // above U+10FFFF
}

}  // namespace
}  // namespace cpgmatch
