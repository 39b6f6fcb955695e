// The study file's keys: the manual (cpgmatch-study(5)) is written from the same table the parser checks
// files against, and every key in it really is read.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include <CLI/CLI.hpp>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/runtime/man_pages.hpp"
#include "cpgmatch/study/study_file_keys.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch {
namespace {

const study::SpecDefaults kShipped = study::SpecDefaults::shipped();

std::string error_of(const std::string& yaml) {
  try {
    (void)study::StudySpec::resolve(yaml, "keys.yaml", kShipped);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(StudyFileKeys, EveryListedKeyIsReadAndAValueOfTheWrongShapeIsRefusedNamingIt) {
  // A nested sequence is the wrong shape for every key (none takes a list of lists), so a key the parser
  // silently ignored would resolve without an error here.
  for (const std::string& key : study::top_level_study_file_keys()) {
    const std::string yaml = key == "name" ? "name: [1, [2]]\n" : "name: s\n" + key + ": [1, [2]]\n";
    const std::string error = error_of(yaml);
    EXPECT_NE(error, "") << key << ": a wrong value resolved";
    EXPECT_NE(error.find(key), std::string::npos) << key << ": the error does not name it: " << error;
  }
}

TEST(StudyFileKeys, AKeyTheManualDoesNotListIsRefusedWithFileAndLine) {
  const std::string error = error_of("name: s\nbudget: 4\nbudgte: 5\n");
  EXPECT_NE(error.find("keys.yaml:3"), std::string::npos) << error;
  EXPECT_NE(error.find("budgte"), std::string::npos) << error;
}

TEST(StudyFileKeys, NestedKeysBelongToAListedTopLevelKeyAndEveryKeyIsDescribed) {
  const auto top = study::top_level_study_file_keys();
  const std::set<std::string> top_set(top.begin(), top.end());
  EXPECT_EQ(top_set.size(), top.size()) << "a key is listed twice";
  for (const study::StudyFileKey& key : study::study_file_keys()) {
    const std::string name = key.key;
    const auto dot = name.find('.');
    if (dot != std::string::npos) {
      EXPECT_TRUE(top_set.count(name.substr(0, dot))) << name;
    }
    EXPECT_GT(std::string(key.description).size(), 10u) << name;
    EXPECT_GT(std::string(key.value).size(), 2u) << name;
  }
}

TEST(ManPages, RoffEscapesWhatRoffWouldReadAsMarkupAndWritesNonAsciiAsGlyphs) {
  EXPECT_EQ(runtime::roff_escape("mean ± sd"), "mean \\[u00B1] sd");
  EXPECT_EQ(runtime::roff_escape("--budget"), "\\-\\-budget");
  EXPECT_EQ(runtime::roff_escape(".hidden\n'quoted"), "\\&.hidden\n\\&'quoted");
  EXPECT_EQ(runtime::roff_escape("a\\b"), "a\\eb");
  EXPECT_EQ(runtime::roff_escape("20 °C, 30°"), "20 \\[u00B0]C, 30\\[u00B0]");
  EXPECT_EQ(runtime::roff_escape("\xff"), "\\[u00FF]");  // a stray byte stands for itself, nothing is lost
}

TEST(ManPages, OnePagePerVisibleCommandWithItsOptionsAndLinks) {
  CLI::App app{"tool: does things"};
  int budget = 150;
  auto* study = app.add_subcommand("study", "studies");
  auto* run = study->add_subcommand("run", "run a study");
  run->add_option("--budget", budget, "rollouts, mean ± sd")->capture_default_str()->envname("TOOL_BUDGET");
  bool secret = false;
  run->add_flag("--secret-flag", secret, "for the build")->group("");
  app.add_subcommand("hidden", "not for users")->group("");
  const auto pages = runtime::man_pages_for(app, "tool", "tool 1.0", {"tool-file(5)"});
  ASSERT_EQ(pages.size(), 3u);
  EXPECT_EQ(pages[0].file_name, "tool.1");
  EXPECT_EQ(pages[1].file_name, "tool-study.1");
  EXPECT_EQ(pages[2].file_name, "tool-study-run.1");
  const std::string& page = pages[2].text;
  EXPECT_NE(page.find(".TH \"TOOL\\-STUDY\\-RUN\" 1"), std::string::npos) << page;
  EXPECT_NE(page.find("\\fB\\-\\-budget\\fR \\fIINT\\fR"), std::string::npos) << page;
  EXPECT_NE(page.find("default: 150; environment: TOOL_BUDGET"), std::string::npos) << page;
  EXPECT_NE(page.find("mean \\[u00B1] sd"), std::string::npos) << page;
  EXPECT_EQ(page.find("secret"), std::string::npos) << "a hidden option is in the manual";
  EXPECT_NE(page.find(".BR tool\\-study (1)"), std::string::npos) << page;
  EXPECT_NE(page.find(".BR tool\\-file (5)"), std::string::npos) << page;
  EXPECT_EQ(pages[0].text.find("hidden"), std::string::npos) << "a hidden subcommand is in the manual";
  EXPECT_NE(pages[1].text.find("tool\\-study\\-run\\fR(1)"), std::string::npos) << pages[1].text;
}

}  // namespace
}  // namespace cpgmatch
