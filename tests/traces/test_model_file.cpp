// `model: FILE` in a study file (model_file.hpp): the client sends the file's content, the spec holds it
// (its hash covers it) and records the file's name; errors name the study file's or the model file's line.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/study/model_file.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::study {
namespace {

namespace fs = std::filesystem;

class ModelFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("model-file-" + std::to_string(::getpid()));
    fs::create_directories(dir_ / "models");
  }
  void TearDown() override { fs::remove_all(dir_); }
  void write(const fs::path& path, const std::string& text) { std::ofstream(dir_ / path) << text; }
  std::string study_path() const { return (dir_ / "s.yaml").string(); }
  StudySpec resolve(const std::string& study) const {
    return StudySpec::resolve(with_model_file(study, study_path()), study_path(), SpecDefaults::shipped());
  }
  fs::path dir_;
};

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST_F(ModelFile, TheSpecHoldsTheFilesContentAndNamesTheFile) {
  write("models/cal.yaml", "# calibrated\nknee_spring:\n  stiffness_nm_per_rad: {value: 11.9, source: \"calibrated\"}\n");
  const StudySpec spec = resolve("name: s\nbudget: 20\nmodel: models/cal.yaml\n");
  EXPECT_EQ(spec.model().knee_spring.stiffness_nm_per_rad, 11.9);
  EXPECT_EQ(spec.tree()["model"]["knee_spring"]["stiffness_nm_per_rad"]["source"], "calibrated");
  EXPECT_EQ(spec.tree()["study"]["model"], "models/cal.yaml");
  EXPECT_FALSE(spec.tree()["study"].contains(kModelFileTextKey));
  // The same values inline are the same model; another content is another spec.
  const StudySpec inline_spec = StudySpec::resolve(
      "name: s\nbudget: 20\nmodel: {knee_spring: {stiffness_nm_per_rad: {value: 11.9, source: calibrated}}}\n", "i.yaml",
      SpecDefaults::shipped());
  EXPECT_EQ(inline_spec.tree()["model"], spec.tree()["model"]);
  write("models/cal.yaml", "knee_spring:\n  stiffness_nm_per_rad: {value: 11.8, source: \"calibrated\"}\n");
  EXPECT_NE(resolve("name: s\nbudget: 20\nmodel: models/cal.yaml\n").sha256(), spec.sha256());
  // The spec written back as a study file resolves to the very same spec.
  EXPECT_EQ(StudySpec::resolve(spec.to_study_yaml(), "again.yaml", SpecDefaults::shipped()).sha256(), spec.sha256());
}

TEST_F(ModelFile, ErrorsNameTheFileAndTheLine) {
  write("cal.yaml", "knee_spring:\n  stiffness_nm_per_rad: 12.0\n  stifness: 3.0\n");
  EXPECT_NE(error_of([&] { resolve("name: s\nmodel: cal.yaml\n"); }).find("cal.yaml:3"), std::string::npos)
      << error_of([&] { resolve("name: s\nmodel: cal.yaml\n"); });
  const std::string missing = error_of([&] { resolve("name: s\nbudget: 20\nmodel: nowhere.yaml\n"); });
  EXPECT_NE(missing.find("s.yaml:3"), std::string::npos) << missing;
  EXPECT_NE(missing.find("nowhere.yaml"), std::string::npos) << missing;
  // A submit that names a file but does not carry it (not through the client): refused, naming it.
  const std::string bare =
      error_of([&] { StudySpec::resolve("name: s\nmodel: cal.yaml\n", "s.yaml", SpecDefaults::shipped()); });
  EXPECT_NE(bare.find("s.yaml:2"), std::string::npos) << bare;
  EXPECT_NE(bare.find("does not carry its content"), std::string::npos) << bare;
  // The key is the client's to write.
  EXPECT_NE(error_of([&] { with_model_file("name: s\nmodel_file_text: \"x: 1\"\n", study_path()); }).find("s.yaml:2"),
            std::string::npos);
}

TEST_F(ModelFile, AStudyWithoutAModelFileIsSentAsItIs) {
  const std::string text = "name: s\nmodel: {knee_spring: {stiffness_nm_per_rad: 20}}\n";
  EXPECT_EQ(with_model_file(text, study_path()), text);
  EXPECT_EQ(with_model_file("name: s\n", study_path()), "name: s\n");
}

}  // namespace
}  // namespace cpgmatch::study
