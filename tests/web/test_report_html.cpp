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
  c.parameters = {{"overswing", "1", 0.0, 0.5}, {"frequency", "Hz", 0.5, 2.0}};
  c.legs = {"FL", "FR", "HL", "HR"};
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
  EXPECT_NE(html.find("<tr><td>frequency</td><td>Hz (0.5 .. 2)</td><td class=\"num\">0.95</td><td class=\"num\">1</td></tr>"),
            std::string::npos);
  // The search space's order, not the alphabet's.
  EXPECT_LT(html.find("<td>overswing</td>"), html.find("<td>frequency</td>"));
  EXPECT_NE(html.find("0.47 observed, 0.45 ± 0.02 GP posterior"), std::string::npos);
  EXPECT_NE(html.find("falls      3   (paper 11)"), std::string::npos);
}

// A hexapod's report names its six legs and its own parameters, and no Morti leg anywhere.
TEST(ReportHtml, AHexapodsReportNamesItsSixLegsAndItsOwnParameters) {
  ReportContent c = content();
  c.legs = {"L1", "R1", "L2", "R2", "L3", "R3"};
  c.parameters = {{"hip_amplitude", "rad", 0.1, 0.45}, {"duty_factor_front", "", 0.3, 0.75}};
  c.report = json::parse(R"({
    "best": {"rollout": 4, "cost": 0.5, "fell": false, "speed_mps": 0.4, "normalized_torque": 3.0,
             "params": {"hip_amplitude": 0.3, "duty_factor_front": 0.6, "frequency": 1.5}},
    "recommended": null})");
  c.leg_energy_rollout = "rollout 4 (lowest cost)";
  for (std::size_t leg = 0; leg < c.legs.size(); ++leg) {
    c.leg_energy.push_back({c.legs[leg], 10.0 + leg, 20.0 + leg, 30.0 + leg, 40.0 + leg});
  }
  c.figures = {{"fig4", fig4_caption(c.legs), std::string("\x89PNG\r\n\x1a\n", 8)}};
  const std::string html = report_html(c);
  EXPECT_NE(html.find("<h2>Legs: 6 (L1 R1 L2 R2 L3 R3)</h2>"), std::string::npos);
  EXPECT_NE(html.find("<tr><td>L3</td><td class=\"num\">14</td><td class=\"num\">24</td><td class=\"num\">34</td>"
                      "<td class=\"num\">44</td></tr>"), std::string::npos) << "the fifth leg's row, under its name";
  EXPECT_NE(html.find("<tr><td>hip_amplitude</td><td>rad (0.1 .. 0.45)</td>"), std::string::npos);
  EXPECT_NE(html.find("<tr><td>duty_factor_front</td><td>fraction (0.3 .. 0.75)</td>"), std::string::npos);
  EXPECT_NE(html.find("<tr><td>frequency</td><td>fixed</td>"), std::string::npos) << "held by the robot's preset";
  const std::string caption = fig4_caption(c.legs);
  EXPECT_NE(caption.find("the 6 legs' coupled phases, L1's hip and knee with stance shaded, and the feedback of L1 and R1"),
            std::string::npos) << caption;
  EXPECT_NE(html.find(html_escape(caption)), std::string::npos);
  for (const char* morti : {"FL", "FR", "HL", "HR"}) {
    EXPECT_EQ(html.find(morti), std::string::npos) << "Morti's leg " << morti << " in a hexapod's report";
  }
}

TEST(ReportHtml, AStudyWithoutARolloutSaysThereIsNoGait) {
  ReportContent c = content();
  c.report = json::parse(R"({"best": {"rollout": 0}, "recommended": null})");
  EXPECT_NE(report_html(c).find("No rollout ran"), std::string::npos);
}

}  // namespace
}  // namespace cpgmatch::cli
