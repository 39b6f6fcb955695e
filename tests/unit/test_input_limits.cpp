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

// A study text of exactly `bytes` bytes: a name, then a comment filling the rest, then `tail`.
std::string padded_study(std::size_t bytes, const std::string& tail) {
  std::string text = "name: a\n#";
  text += std::string(bytes - text.size() - tail.size() - 1, 'x');
  return text + "\n" + tail;
}

TEST(InputLimits, AYamlTextOverOneMebibyteIsRefusedBeforeParsingNamingSourceAndLimit) {
  EXPECT_EQ(study_error(padded_study(kMaxYamlBytes, "")), "");  // the limit itself is allowed
  // One byte more is refused, and before parsing: the unclosed quote at its end is not what is reported.
  const std::string e = study_error(padded_study(kMaxYamlBytes + 1, "seed: \"1"));
  EXPECT_NE(e.find("s.yaml"), std::string::npos) << e;
  EXPECT_NE(e.find("1 MiB (1048576 bytes)"), std::string::npos) << e;
  EXPECT_EQ(e.find("quoted"), std::string::npos) << e;
  // A file is not even read past the limit.
  const std::string path = ::testing::TempDir() + "/huge.yaml";
  std::ofstream(path) << padded_study(4 * kMaxYamlBytes, "");
  try {
    (void)YamlReader::from_file(path);
    ADD_FAILURE() << "a 4 MiB file loaded";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find(path + ": larger than 1 MiB"), std::string::npos) << error.what();
  }
}

TEST(InputLimits, ASecondYamlDocumentIsRefusedWithItsLine) {
  // yaml-cpp's Load() kept the first document and dropped the rest without a word.
  const struct {
    const char* yaml;
    const char* where;
  } bad[] = {
      {"name: a\n---\nname: b\n", "s.yaml:2"},
      {"name: a\n---\n", "s.yaml:2"},
      {"---\nname: a\nbudget: 20\n--- # again\nbudget: 30\n", "s.yaml:4"},
      {"name: a\n...\nbudget: 30\n", "s.yaml:3"},
      {"name: a\n...\n---\nname: b\n", "s.yaml:3"},
  };
  for (const auto& b : bad) {
    const std::string e = study_error(b.yaml);
    EXPECT_NE(e.find(b.where), std::string::npos) << b.yaml << " -> " << e;
    EXPECT_NE(e.find("second YAML document"), std::string::npos) << b.yaml << " -> " << e;
  }
  // One document, with its optional markers, a directive or a comment after its end, still loads.
  EXPECT_EQ(study_error("---\nname: a\n...\n"), "");
  EXPECT_EQ(study_error("%YAML 1.2\n---\nname: a\n"), "");
  EXPECT_EQ(study_error("name: a\n...\n# the end\n"), "");
  EXPECT_EQ(study_error("name: a\n..."), "");
}

TEST(InputLimits, AnUnterminatedQuotedStringIsAnErrorNamingTheLineItOpensOn) {
  // yaml-cpp 0.7 took the rest of the file as the string when the file ended with a line break.
  const struct {
    const char* yaml;
    const char* where;
  } bad[] = {
      {"name: \"abc\nbudget: 10\n", "s.yaml:1"},
      {"budget: 10\nname: 'abc\n\n", "s.yaml:2"},
      {"budget: 10\nname: \"abc", "s.yaml:2"},                  // no final line break
      {"budget: 10\nname: \"abc\n---\nseed: 1\n", "s.yaml:2"},  // a document marker inside it
      {"name: a\nparameters:\n  - {name: x, low: 0, high: 1}\n  - {name: 'y, low: 0, high: 1}\n", "s.yaml:4"},
  };
  for (const auto& b : bad) {
    const std::string e = study_error(b.yaml);
    EXPECT_NE(e.find(b.where), std::string::npos) << b.yaml << " -> " << e;
    EXPECT_NE(e.find("never closed"), std::string::npos) << b.yaml << " -> " << e;
  }
  // Quoted strings that close, over lines too, and a plain one with an apostrophe, load.
  EXPECT_EQ(study_error("name: \"a\n  b\"\nacquisition: 'ei'\n"), "");
  EXPECT_EQ(study_error("name: it's\n"), "");
}

TEST(InputLimits, OtherYamlSyntaxErrorsStillNameALineOfTheText) {
  const std::string e = study_error("name: a\nfixed: {frequency: 1\n");  // a flow mapping never closed
  EXPECT_NE(e.find("s.yaml:2: malformed YAML"), std::string::npos) << e;
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
