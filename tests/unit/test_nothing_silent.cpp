// Issue 34, "nothing lost, nothing silent", the parts that need no process: model values outside their
// physical range, ODE's failures as an outcome instead of SIGABRT, constraints that divide by zero or leave
// nothing feasible, special files named by a study, and the escaping of echoed input.
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/sim/morti_model.hpp"
#include "cpgmatch/sim/ode_errors.hpp"
#include "cpgmatch/sim/physical_ranges.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/study/model_file.hpp"
#include "cpgmatch/study/study_config.hpp"
#include "cpgmatch/study/study_spec.hpp"
#include "cpgmatch/text.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch {
namespace {

namespace fs = std::filesystem;

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

std::string model_error(const std::string& yaml) {
  return error_of([&] { (void)sim::parse_model_file(YamlReader::from_string(yaml, "m.yaml")); });
}

// ---- physical ranges -----------------------------------------------------------------------------

TEST(PhysicalRanges, AbsurdButFiniteValuesAreRefusedNamingFileLineAndField) {
  // The values: each passed "> 0", then aborted ODE, ran as "completed", or ran until killed.
  struct Case {
    std::string yaml, where, field;
  };
  const std::vector<Case> cases = {
      {"trunk: {mass_kg: {value: 1.0e308}}\n", "m.yaml:1", "trunk.mass_kg"},
      {"trunk:\n  mass_kg: {value: 1.0e-320}\n", "m.yaml:2", "trunk.mass_kg"},
      {"contact: {stiffness_n_per_m: 1.0e308}\n", "m.yaml:1", "contact.stiffness_n_per_m"},
      {"simulation:\n  physics_rate_hz: 1.0e9\n", "m.yaml:2", "simulation.physics_rate_hz"},
      {"femur: {mass_kg: 5000}\n", "m.yaml:1", "femur.mass_kg"},
      {"knee_spring: {damping_nm_s_per_rad: 1e9}\n", "m.yaml:1", "knee_spring.damping_nm_s_per_rad"},
      {"hip_motor: {reflected_inertia_kg_m2: 1e6}\n", "m.yaml:1", "hip_motor.reflected_inertia_kg_m2"},
      {"hip_motor: {kp_nm_per_rad: -5}\n", "m.yaml:1", "hip_motor.kp_nm_per_rad"},
      {"knee_motor: {bandwidth_per_s: 5000}\n", "m.yaml:1", "knee_motor.bandwidth_per_s"},
      {"simulation: {gravity_m_s2: 1e12}\n", "m.yaml:1", "simulation.gravity_m_s2"},
  };
  for (const Case& c : cases) {
    const std::string e = model_error(c.yaml);
    EXPECT_NE(e.find(c.where), std::string::npos) << c.yaml << " -> " << e;
    EXPECT_NE(e.find("'" + c.field + "'"), std::string::npos) << c.yaml << " -> " << e;
    EXPECT_NE(e.find("physical range"), std::string::npos) << c.yaml << " -> " << e;
  }
  // The shipped model and every scenario model are inside every range.
  for (const auto& entry : fs::directory_iterator(fs::path(sim::config_dir()) / "model")) {
    EXPECT_NO_THROW((void)sim::load_model_file(entry.path().string())) << entry.path();
  }
}

TEST(PhysicalRanges, TheCheckNamesTheFirstValueOutsideAndItsRange) {
  sim::PlanarLegModel m;
  EXPECT_FALSE(sim::check_physical_ranges(m).has_value());
  m.shank.mass_kg = 1e308;
  const auto p = sim::check_physical_ranges(m);
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(p->section, "shank");
  EXPECT_EQ(p->key, "mass_kg");
  EXPECT_NE(p->message.find("[0.001, 1000]"), std::string::npos) << p->message;
  m.shank.mass_kg = std::nan("");  // NaN is outside every range
  EXPECT_TRUE(sim::check_physical_ranges(m).has_value());
}

// ---- ODE's failures ------------------------------------------------------------------------------

// A model built in code skips the parser's ranges: the rollout takes ODE to its assertion. The process must
// end with the reason and exit 1 (no hook) or through the hook, never SIGABRT (134).
sim::SimRolloutJob absurd_job() {
  sim::SimRolloutJob job;
  job.model = sim::load_model_file(sim::default_model_path());
  job.model.trunk_mass_kg = 1e308;
  job.settings = parse_rollout_settings(YamlReader::from_file(sim::default_rollout_settings_path()));
  job.settings.entrain_s = 0.5;
  job.settings.eval_s = 0.5;
  return job;
}

TEST(OdeFailure, AnOdeAssertionEndsTheProcessWithItsReasonNotSigabrt) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT((void)sim::run_sim_rollout(absurd_job()), testing::ExitedWithCode(1),
              "the simulation failed: ODE (INTERNAL )?ERROR");
}

void print_diverged_and_exit(const std::string& reason) {
  std::fprintf(stderr, "HOOK diverged: %s\n", reason.c_str());
  std::fflush(stderr);
  _exit(0);
}

TEST(OdeFailure, TheHookTurnsItIntoAnOutcome) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        sim::set_ode_failure_hook(print_diverged_and_exit);
        (void)sim::run_sim_rollout(absurd_job());
      },
      testing::ExitedWithCode(0), "HOOK diverged: ODE");
}

// ---- constraints -----------------------------------------------------------------------------------

std::string study_error(const std::string& yaml) {
  return error_of([&] { (void)study::StudySpec::resolve(yaml, "s.yaml", study::SpecDefaults::shipped()); });
}

TEST(ConstraintsAtSubmit, DivisionsThatCanBeZeroAreRefusedNamingTheLine) {
  const std::vector<std::string> refused = {
      "hip_offset / 0 <= 1",
      "hip_offset / (hip_amplitude - hip_amplitude) <= 1",
      "1 / (hip_offset * 0) >= -1",
      "1 / hip_offset <= 5",  // hip_offset's range holds 0
      "hip_amplitude / (frequency - 1) <= 5",  // frequency is not searched: its whole valid range counts
  };
  for (const auto& c : refused) {
    const std::string e = study_error(fmt::format("name: c\nbudget: 30\nconstraints:\n  - \"{}\"\n", c));
    EXPECT_NE(e.find("s.yaml:4"), std::string::npos) << c << " -> " << e;
    EXPECT_NE(e.find("division by zero"), std::string::npos) << c << " -> " << e;
  }
  // A divisor bounded away from 0 is fine: hip_amplitude is in [0.05, 0.65].
  EXPECT_EQ(study_error("name: c\nbudget: 30\nconstraints: [\"hip_offset / hip_amplitude <= 5\"]\n"), "");
}

TEST(ConstraintsAtSubmit, InfeasibleConstraintsAreRefusedAtResolveNamingTheLine) {
  // Before: resolved, stored and shown running, then refused by the optimizer as an "internal error".
  const std::string e = study_error("name: c\nbudget: 30\nconstraints:\n  - \"hip_offset >= 100\"\n");
  EXPECT_NE(e.find("s.yaml:4"), std::string::npos) << e;  // the constraint's own line
  EXPECT_NE(e.find("feasible"), std::string::npos) << e;
}

// ---- files a study names ------------------------------------------------------------------------

class SpecialFiles : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / fmt::format("cpgmatch-special-{}", getpid());
    fs::create_directories(dir_);
    fifo_ = (dir_ / "pipe.yaml").string();
    ASSERT_EQ(mkfifo(fifo_.c_str(), 0600), 0);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string study_naming(const std::string& model) {
    const std::string path = (dir_ / "s.yaml").string();
    std::ofstream(path) << "name: s\nmodel: " << model << "\n";
    return path;
  }
  fs::path dir_;
  std::string fifo_;
};

TEST_F(SpecialFiles, AModelThatIsNotARegularFileIsRefusedBeforeReading) {
  // Before: /dev/zero grew past 5 GB, a named pipe hung for ever. Each must be refused at once.
  for (const std::string& model : {std::string("/dev/zero"), fifo_, dir_.string(), std::string("/dev/urandom")}) {
    const std::string path = study_naming(model);
    const std::string e = error_of([&] { (void)study::with_model_file(read_text_file(path, path), path); });
    EXPECT_NE(e.find("s.yaml:2"), std::string::npos) << model << " -> " << e;
    EXPECT_NE(e.find("not a regular file"), std::string::npos) << model << " -> " << e;
  }
  // The study file itself, and every YAML file read through YamlReader.
  EXPECT_NE(error_of([&] { (void)read_text_file(fifo_, "--config"); }).find("named pipe"), std::string::npos);
  EXPECT_NE(error_of([&] { (void)YamlReader::from_file(fifo_); }).find("not a regular file"), std::string::npos);
  EXPECT_NE(error_of([&] { (void)YamlReader::from_file("/dev/zero"); }).find("not a regular file"), std::string::npos);
}

TEST_F(SpecialFiles, AModelFileOverTheStudyLimitIsRefusedOnItsSize) {
  const std::string big = (dir_ / "big.yaml").string();
  std::ofstream(big) << "# " << std::string(study::kMaxStudyFileBytes, 'x') << "\n";
  const std::string path = study_naming(big);
  const std::string e = error_of([&] { (void)study::with_model_file(read_text_file(path, path), path); });
  EXPECT_NE(e.find(std::to_string(study::kMaxStudyFileBytes)), std::string::npos) << e;
  // Exactly at the limit together with the study file: refused too (the study text carries it).
  const std::string edge = (dir_ / "edge.yaml").string();
  std::ofstream(edge) << "# " << std::string(study::kMaxStudyFileBytes - 10, 'x') << "\n";
  const std::string p2 = study_naming(edge);
  EXPECT_NE(error_of([&] { (void)study::with_model_file(read_text_file(p2, p2), p2); }).find("more than a study may have"),
            std::string::npos);
}

TEST(ModelFileLines, AModelErrorNamesTheModelFilesOwnLine) {
  // The client appends the model file's text; before, an error named a line of the merged text (":128").
  const std::string model_text = "trunk:\n  mass_kg: {value: 1.0e308}\n";
  const std::string study_text = fmt::format("name: s\nmodel: m.yaml\n{}: {}\n", study::kModelFileTextKey,
                                             nlohmann::json(model_text).dump());
  const std::string e = study_error(study_text);
  EXPECT_NE(e.find("m.yaml:2"), std::string::npos) << e;
  EXPECT_EQ(e.find("(model)"), std::string::npos) << e;
}

// ---- escaping --------------------------------------------------------------------------------------

TEST(EscapeForMessage, ControlsBadBytesAndBidiOverridesAreShownAsEscapes) {
  EXPECT_EQ(escape_for_message("plain name ok"), "plain name ok");
  EXPECT_EQ(escape_for_message("a\x1b[2Jb"), "a\\x1b[2Jb");
  EXPECT_EQ(escape_for_message("line\nnext\ttab\r"), "line\\nnext\\ttab\\r");
  EXPECT_EQ(escape_for_message("bad \xff\xfe byte"), "bad \\xff\\xfe byte");
  EXPECT_EQ(escape_for_message("cut \xe2\x82"), "cut \\xe2\\x82");                // truncated sequence
  EXPECT_EQ(escape_for_message("over\xc0\xaflong"), "over\\xc0\\xaflong");       // overlong '/'
  EXPECT_EQ(escape_for_message("evil\xe2\x80\xaegnp.exe"), "evil\\u202egnp.exe");  // RIGHT-TO-LEFT OVERRIDE
  EXPECT_EQ(escape_for_message("iso\xe2\x81\xa6x"), "iso\\u2066x");
  EXPECT_EQ(escape_for_message("zw\xe2\x80\x8bj"), "zw\\u200bj");
  EXPECT_EQ(escape_for_message("\xc2\x9b" "31m"), "\\u009b31m");  // C1 CSI
  EXPECT_EQ(escape_for_message("caf\xc3\xa9 \xe6\x97\xa5\xf0\x9f\xa6\xbf"), "caf\xc3\xa9 \xe6\x97\xa5\xf0\x9f\xa6\xbf");
  EXPECT_EQ(escape_for_message(std::string(300, 'a'), 10), std::string(10, 'a') + "...");
  EXPECT_EQ(escape_message_lines("first\xe2\x80\xae\n  second\x07"), "first\\u202e\n  second\\x07");
}

TEST(EscapeForMessage, ErrorsThatEchoAStudyFileComeOutEscaped) {
  // A key with a bidi override and a bad byte: the YAML error echoes it, the executable's door escapes it.
  const std::string e = study_error("name: s\nbud\xe2\x80\xaeget: 3\n");
  ASSERT_FALSE(e.empty());
  const std::string shown = escape_message_lines(e);
  EXPECT_EQ(shown.find("\xe2\x80\xae"), std::string::npos) << shown;
  EXPECT_NE(shown.find("\\u202e"), std::string::npos) << shown;
}

}  // namespace
}  // namespace cpgmatch
