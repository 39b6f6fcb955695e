// report.html as text: self-contained (figures as data: URIs, nothing from elsewhere), every user string
// escaped, the gait table from the science report's JSON.
#include <gtest/gtest.h>

#include "report_html.hpp"

namespace cpgmatch::cli {
namespace {

using nlohmann::json;

TEST(ReportHtml, Base64IsRfc4648) {
  EXPECT_EQ(base64(""), "");
  EXPECT_EQ(base64("M"), "TQ==");
  EXPECT_EQ(base64("Ma"), "TWE=");
  EXPECT_EQ(base64("Man"), "TWFu");
  EXPECT_EQ(base64(std::string("\x89PNG\r\n\x1a\n", 8)), "iVBORw0KGgo=");
}

TEST(ReportHtml, EscapesWhatItQuotes) {
  EXPECT_EQ(html_escape(R"(<a href="x">&'</a>)"), "&lt;a href=&quot;x&quot;&gt;&amp;&#39;&lt;/a&gt;");
}

ReportContent content() {
  ReportContent c;
  c.title = "trot <b>study</b> (study 3)";
  c.generated_by = "cpgmatch test";
  c.facts = {{"rollouts", "12"}};
  c.science_table = "falls      3   (paper 11)\n";
  c.report = json::parse(R"({
    "best": {"rollout": 7, "cost": 0.41, "fell": false, "speed_mps": 0.6, "normalized_torque": 12.9,
             "params": {"frequency": 1.0, "overswing": 0.09}},
    "recommended": {"rollout": 9, "predicted_cost": 0.45, "predicted_sd": 0.02, "observed_cost": 0.47, "fell": false,
                    "params": {"frequency": 0.95, "overswing": 0.1}}})");
  c.figures = {{"fig5a", "cost per rollout", std::string("\x89PNG\r\n\x1a\n", 8)}, {"fig6", "torque", ""}};
  c.not_drawn = {"fig6: none of the rollouts that walked has a positive normalised torque"};
  c.study_yaml = "name: trot <b>study</b>\nbudget: 12\n";
  c.spec_json = "{\"terrain\": \"flat\"}";
  return c;
}

TEST(ReportHtml, EmbedsTheFiguresItHasAndSaysWhatWasNotDrawn) {
  const std::string html = report_html(content());
  EXPECT_NE(html.find(R"(src="data:image/png;base64,iVBORw0KGgo=")"), std::string::npos);
  EXPECT_EQ(html.find("id=\"fig6\""), std::string::npos) << "an empty figure is not embedded";
  EXPECT_NE(html.find("none of the rollouts that walked has a positive normalised torque"), std::string::npos);
  // Nothing outside the file: no remote source, no link, no script.
  for (const char* outside : {"src=\"http", "href=", "<script", "url("}) {
    EXPECT_EQ(html.find(outside), std::string::npos) << outside;
  }
}

TEST(ReportHtml, QuotesTheStudyEscapedAndTheGaitBesideTheLowestCost) {
  const std::string html = report_html(content());
  EXPECT_EQ(html.find("<b>study</b>"), std::string::npos) << "a study's name is text, not markup";
  EXPECT_NE(html.find("name: trot &lt;b&gt;study&lt;/b&gt;"), std::string::npos);
  EXPECT_NE(html.find("<th>recommended (rollout 9)</th><th>lowest cost (rollout 7)</th>"), std::string::npos);
  EXPECT_NE(html.find("<tr><td>frequency</td><td class=\"num\">0.95</td><td class=\"num\">1</td></tr>"),
            std::string::npos);
  EXPECT_NE(html.find("0.47 observed, 0.45 ± 0.02 GP posterior"), std::string::npos);
  EXPECT_NE(html.find("falls      3   (paper 11)"), std::string::npos);
}

TEST(ReportHtml, AStudyWithoutARolloutSaysThereIsNoGait) {
  ReportContent c = content();
  c.report = json::parse(R"({"best": {"rollout": 0}, "recommended": null})");
  EXPECT_NE(report_html(c).find("No rollout ran"), std::string::npos);
}

}  // namespace
}  // namespace cpgmatch::cli
