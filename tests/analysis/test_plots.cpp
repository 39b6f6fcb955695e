// The figures are real files: PNGs with the PNG signature, SVGs with drawn data.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "cpgmatch/analysis/gnuplot.hpp"
#include "cpgmatch/analysis/plots.hpp"
#include "cpgmatch/analysis/replicates.hpp"
#include "cpgmatch/analysis/science_report.hpp"
#include "cpgmatch/analysis/sim2real.hpp"
#include "cpgmatch/analysis/trial.hpp"
#include "cpgmatch/domain/report_json.hpp"

namespace cpgmatch::analysis {
namespace {

namespace fs = std::filesystem;

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void expect_figure(const fs::path& dir, const std::string& stem) {
  const std::string png = read(dir / (stem + ".png"));
  ASSERT_GE(png.size(), 8u) << stem;
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << stem;
  const std::string svg = read(dir / (stem + ".svg"));
  EXPECT_NE(svg.find("<svg"), std::string::npos) << stem;
  // gnuplot draws data as <path d='M... L...'>; the L (line-to) means at least two points were joined.
  EXPECT_TRUE(svg.find("d='M") != std::string::npos && svg.find(" L") != std::string::npos) << stem;
}

StudyTrials synthetic_study(int seed) {
  StudyTrials s;
  s.name = "synthetic";
  s.initial_points = 5;
  s.bounds = {{"hip_offset", {-0.3, 0.3}}, {"overswing", {0.0, 0.5}}};
  for (int i = 0; i < 30; ++i) {
    Trial t;
    t.trial_id = i;
    t.ok = true;
    t.fell = (i * 7 + seed) % 9 == 0;
    t.cost = 3.0 + std::sin(i + seed) + 5.0 / (i + 1);
    t.terms = {0.5 / (i + 1), 1.5, 0.8, 0.02, i % 3 ? 0.0 : 0.01};
    t.mean_speed_mps = 0.1 + 0.01 * i;
    t.normalized_torque = 1.0 + 2.0 / (i + 1);
    t.summed_torque_nm = t.normalized_torque * t.mean_speed_mps;
    t.params = {{"hip_offset", -0.3 + 0.02 * i}, {"overswing", 0.5 * std::abs(std::sin(3.0 * i + seed))}};
    if (t.fell) t.cost += 14.0;  // a fall costs 13-19 in a study, a walking gait 0.4-6
    t.energy.electrical_cost_of_transport = 0.5 + 1.0 / (i + 1);
    s.trials.push_back(t);
  }
  return s;
}

class Plots : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!gnuplot_available()) GTEST_SKIP() << "gnuplot is not on PATH: figures cannot be drawn";
    dir_ = fs::temp_directory_path() / fmt_dir();
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  static std::string fmt_dir() { return "cpgmatch-plots-" + std::to_string(::getpid()); }
  fs::path dir_;
};

TEST_F(Plots, StudyFigures) {
  const FigureReport report = plot_study(synthetic_study(0), dir_);
  EXPECT_EQ(report.files.size(), 14u);
  EXPECT_TRUE(report.failed.empty()) << report.failed.front();
  EXPECT_TRUE(report.not_drawn.empty()) << report.not_drawn.front();
  for (const char* stem : {"fig5a", "fig5b", "fig6", "fig6_cot", "param_slices", "param_importance", "param_parallel"}) {
    expect_figure(dir_, stem);
  }
}

// The parameter figures label each axis with the study's own parameter and its unit (a robot's search space).
TEST_F(Plots, ParameterAxesCarryTheirUnits) {
  StudyTrials s = synthetic_study(0);
  s.dimensions = {{"hip_offset", -0.3, 0.3, false, "rad"}, {"overswing", 0.0, 0.5, false, "1"}};
  const FigureReport report = plot_study(s, dir_);
  EXPECT_TRUE(report.failed.empty()) << report.failed.front();
  const std::string slices = read(dir_ / "param_slices.gp");
  EXPECT_NE(slices.find("set xlabel 'hip_offset (rad)'"), std::string::npos);
  EXPECT_NE(slices.find("set xlabel 'overswing'"), std::string::npos) << "a dimensionless one has no unit";
  EXPECT_NE(read(dir_ / "param_parallel.gp").find("\"hip_offset\\n(rad)\" 1"), std::string::npos);
}

TEST_F(Plots, AStudyWithoutEnergyDataDrawsFig6AloneAndSaysWhy) {
  StudyTrials s = synthetic_study(0);
  for (auto& t : s.trials) t.energy = EnergyMeasures{};
  const FigureReport report = plot_study(s, dir_);
  EXPECT_EQ(report.files.size(), 12u);
  EXPECT_FALSE(fs::exists(dir_ / "fig6_cot.png"));
  ASSERT_EQ(report.not_drawn.size(), 1u);
  EXPECT_EQ(report.not_drawn[0].rfind("fig6_cot:", 0), 0u) << report.not_drawn[0];
}

// A rollout trace as `cpgmatch rollout --trace` writes it, 6 s at 500 Hz and 1 Hz, each leg's phase (cycles,
// 0..1) offset by its entry of `offsets` (one per leg of `legs`, Morti's FL, FR, HL, HR by default).
void write_trace(const fs::path& csv, const std::vector<double>& offsets,
                 const std::vector<std::string>& legs = {"FL", "FR", "HL", "HR"}) {
  std::ofstream out(csv);
  out << "time_s,x_m";
  for (const std::string& leg : legs) {
    for (const char* q : {"_phase", "_hip_target_rad", "_hip_rad", "_knee_target_rad", "_knee_rad", "_contact", "_ltd",
                          "_etd", "_eto", "_lto"}) {
      out << ',' << leg << q;
    }
  }
  out << '\n';
  for (int k = 0; k < 3000; ++k) {
    const double t = 0.002 * k;
    out << t << ',' << 0.3 * t;
    for (std::size_t leg = 0; leg < legs.size(); ++leg) {
      const double phase = std::fmod(t + offsets[leg], 1.0);
      const bool stance = phase < 0.6;
      out << ',' << phase << ',' << 0.2 * std::sin(6.2831853 * phase) << ',' << 0.19 * std::sin(6.2831853 * phase) << ','
          << 0.5 << ',' << 0.48 << ',' << stance << ',' << (k % 200 < 20) << ',' << (k % 300 < 10) << ',' << (k % 250 < 30)
          << ',' << 0;
    }
    out << '\n';
  }
}

TEST_F(Plots, TraceFigureOfATrotDrawsEveryLegAndNamesThePairsInPhase) {
  fs::create_directories(dir_);
  write_trace(dir_ / "trot.csv", {0.0, 0.5, 0.5, 0.0});  // FL with HR, FR with HL
  const auto files = plot_trace(dir_ / "trot.csv", dir_, 4.0);
  EXPECT_EQ(files.size(), 2u);
  expect_figure(dir_, "fig4");
  // Each leg's phase in a row of its own: one shared axis drew FL under HR and FR under HL.
  const std::string script = read(dir_ / "fig4.gp");
  for (const char* row : {"u 1:(3+0.8*", "u 1:(2+0.8*", "u 1:(1+0.8*", "u 1:(0+0.8*"}) {
    EXPECT_NE(script.find(row), std::string::npos) << row;
  }
  EXPECT_NE(script.find("in phase: FL = HR, FR = HL"), std::string::npos);
}

TEST_F(Plots, TraceFigureOfAWalkNamesNoPair) {
  fs::create_directories(dir_);
  write_trace(dir_ / "walk.csv", {0.0, 0.5, 0.25, 0.75});
  plot_trace(dir_ / "walk.csv", dir_, 4.0);
  EXPECT_NE(read(dir_ / "fig4.gp").find("no two legs in phase"), std::string::npos);
}

// A hexapod's trace (issue 31): a row per leg of its own, its first leg in the joint panels, bands for its first two.
TEST_F(Plots, TraceFigureOfAHexapodDrawsItsSixLegs) {
  fs::create_directories(dir_);
  write_trace(dir_ / "tripod.csv", {0.0, 0.5, 0.5, 0.0, 0.0, 0.5}, {"L1", "R1", "L2", "R2", "L3", "R3"});
  plot_trace(dir_ / "tripod.csv", dir_, 4.0);
  expect_figure(dir_, "fig4");
  const std::string script = read(dir_ / "fig4.gp");
  for (const char* row : {"u 1:(5+0.8*", "u 1:(0+0.8*", "'R3' 0.4", "grey: L1 stance", "'L1 hip, rad'", "'L1 LTD' 8",
                          "'R1 LTO' 1"}) {
    EXPECT_NE(script.find(row), std::string::npos) << row;
  }
  EXPECT_NE(script.find("in phase: L1 = R2, L1 = L3, R1 = L2, R1 = R3, L2 = R3, R2 = L3"), std::string::npos);
  EXPECT_EQ(script.find("FL"), std::string::npos) << "no Morti leg in a hexapod's figure";
}

TEST_F(Plots, TraceWithoutTheColumnsIsAClearError) {
  fs::create_directories(dir_);
  std::ofstream(dir_ / "bad.csv") << "time_s,foo\n0,1\n";
  const auto error_of = [&](const char* file) {
    try {
      plot_trace(dir_ / file, dir_);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_NE(error_of("bad.csv").find("0 legs (columns LEG_phase)"), std::string::npos) << error_of("bad.csv");
  // A leg with a phase but no joint columns: the first missing one is named.
  std::ofstream(dir_ / "half.csv") << "time_s,FL_phase\n0,0.5\n";
  EXPECT_NE(error_of("half.csv").find("no column 'FL_hip_target_rad'"), std::string::npos) << error_of("half.csv");
}

// The number after each occurrence of `key` in text (e.g. the upper ends of "set yrange [lo:hi]").
std::vector<std::string> after_each(const std::string& text, const std::string& key) {
  std::vector<std::string> out;
  for (std::size_t at = text.find(key); at != std::string::npos; at = text.find(key, at + 1)) {
    const std::size_t start = at + key.size();
    out.push_back(text.substr(start, text.find_first_of("]\n,", start) - start));
  }
  return out;
}

bool mentions(const std::vector<std::string>& lines, const std::string& what) {
  for (const auto& l : lines) {
    if (l.find(what) != std::string::npos) return true;
  }
  return false;
}

TEST_F(Plots, Fig6DrawsEveryFallInsideItsXRange) {
  StudyTrials s = synthetic_study(0);
  const int falls = static_cast<int>(std::count_if(s.trials.begin(), s.trials.end(), [](const Trial& t) { return t.fell; }));
  ASSERT_GE(falls, 3);
  plot_study(s, dir_);
  const std::string script = read(dir_ / "fig6.gp");
  // Falls cost the most: they are the last ranks, and each shaded bar must end inside the axis.
  const auto ranges = after_each(script, "set xrange [0.5:");
  ASSERT_FALSE(ranges.empty());
  const double x_end = std::stod(ranges.front());
  EXPECT_DOUBLE_EQ(x_end, 30.5);  // every one of the 30 rollouts ran
  const auto bars = after_each(script, " to ");
  int inside = 0;
  for (const auto& b : bars) {
    if (b.find("graph 1") == std::string::npos && std::stod(b) <= x_end) ++inside;
  }
  EXPECT_EQ(inside, 2 * falls) << "each fall's bar, drawn into the PNG and the SVG, ends inside the x-range";
}

TEST_F(Plots, Fig5aDrawsFallsInABandAboveTheWalkingCosts) {
  StudyTrials s = synthetic_study(0);
  double lowest_fall = 1e9, highest_walk = 0.0;
  for (const auto& t : s.trials) {
    if (t.fell) lowest_fall = std::min(lowest_fall, t.cost);
    else highest_walk = std::max(highest_walk, t.cost);
  }
  plot_study(s, dir_);
  const std::string script = read(dir_ / "fig5a.gp");
  // Two panels per rendering (PNG, SVG): the fall band's range, then the walking costs' range.
  const auto tops = after_each(script, "set yrange [");
  ASSERT_EQ(tops.size(), 4u) << script;
  const double walk_top = std::stod(tops[1].substr(tops[1].find(':') + 1));
  const double band_bottom = std::stod(tops[0].substr(0, tops[0].find(':')));
  EXPECT_GT(walk_top, highest_walk);
  EXPECT_LT(walk_top, lowest_fall) << "the walking panel must not stretch to the falls";
  EXPECT_LT(band_bottom, lowest_fall);
}

TEST_F(Plots, Fig5bKeepsFallMarkersOffTheTermsAndTheFloor) {
  plot_study(synthetic_study(0), dir_);
  const std::string script = read(dir_ / "fig5b.gp");
  const std::string png_part = script.substr(0, script.find("set terminal svg"));
  const auto plots = after_each(png_part, "\nplot ");
  ASSERT_EQ(plots.size(), 3u) << "a fall strip, the log panel, the strip below its floor";
  EXPECT_TRUE(mentions({plots[0]}, "$4==1")) << "the first strip marks the falls";
  const std::string log_panel = png_part.substr(png_part.find("set logscale y"));
  const std::string log_plot = log_panel.substr(log_panel.find("plot "), log_panel.find('\n', log_panel.find("plot ")) - log_panel.find("plot "));
  EXPECT_EQ(log_plot.find("$4"), std::string::npos) << "no fall marker on the log axis: " << log_plot;
  EXPECT_NE(log_plot.find(">=0.001"), std::string::npos) << "only terms at or above the floor on the log axis";
  EXPECT_EQ(script.find("set datafile missing"), std::string::npos) << "lines must break where a term left the axis";
}

TEST_F(Plots, AStudyWithoutPositiveTorqueDrawsTheRestAndSaysWhatItCannot) {
  StudyTrials s = synthetic_study(1);
  for (auto& t : s.trials) t.normalized_torque = 0.0;  // fake rollouts measure no torque
  const FigureReport report = plot_study(s, dir_);
  EXPECT_TRUE(report.failed.empty()) << report.failed.front();
  EXPECT_TRUE(mentions(report.not_drawn, "fig6: none of the")) << "it says why the torque axis is empty";
  for (const char* stem : {"fig5a", "fig5b", "fig6", "param_slices", "param_parallel"}) {
    EXPECT_TRUE(fs::exists(dir_ / (std::string(stem) + ".png"))) << stem;
  }
  EXPECT_EQ(read(dir_ / "fig6.gp").find("set logscale y"), std::string::npos) << "no log axis without a positive value";
}

TEST_F(Plots, AStudyWhereNothingRanIsAllReasonsAndNoFailure) {
  StudyTrials s = synthetic_study(0);
  for (auto& t : s.trials) t.ok = false;
  const FigureReport report = plot_study(s, dir_);
  EXPECT_TRUE(report.files.empty());
  EXPECT_TRUE(report.failed.empty());
  EXPECT_EQ(report.not_drawn.size(), 7u);  // fig5a, fig5b, fig6, fig6_cot and the three parameter figures
  EXPECT_TRUE(mentions(report.not_drawn, "fig5a: no rollout ran"));
  EXPECT_TRUE(mentions(report.not_drawn, "fig6_cot: "));
}

TEST_F(Plots, AStudyWhereEveryRolloutFellStillDrawsItsCostsAndTerms) {
  StudyTrials s = synthetic_study(0);
  for (auto& t : s.trials) t.fell = true;
  const FigureReport report = plot_study(s, dir_);
  EXPECT_TRUE(report.failed.empty()) << report.failed.front();
  expect_figure(dir_, "fig5a");
  expect_figure(dir_, "fig5b");
  EXPECT_TRUE(mentions(report.not_drawn, "fig6: none of the 0 rollouts that walked"));
}

TEST_F(Plots, ReplicateFigures) {
  std::vector<StudyTrials> studies = {synthetic_study(1), synthetic_study(2), synthetic_study(3)};
  std::vector<nlohmann::json> reports;
  ReportOptions o;
  o.windows = {{1, 5}, {6, 15}, {16, 30}};
  for (const auto& s : studies) reports.push_back(to_json(science_report(s, o)));
  plot_replicates(studies, aggregate_replicates(reports), dir_);
  expect_figure(dir_, "replicates_min_cost");
  expect_figure(dir_, "replicates_feedback");
}

TEST(Gnuplot, AFailingScriptNamesTheScriptAndQuotesGnuplot) {
  if (!gnuplot_available()) GTEST_SKIP() << "gnuplot is not on PATH";
  const fs::path dir = fs::temp_directory_path() / ("cpgmatch-badplot-" + std::to_string(::getpid()));
  try {
    render_figure(dir, "broken", "plot this_is_not_gnuplot(", 400, 300);
    FAIL() << "expected PlotError";
  } catch (const PlotError& e) {
    EXPECT_NE(std::string(e.what()).find("broken.gp"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cpgmatch::analysis

namespace cpgmatch::analysis {
namespace {

// A synthetic rollout (cpgmatch-sim-worker --fake-rollout-ms) is marked from its report to the figure data:
// the report's JSON carries the mark, the analysis reads it, and neither a figure's data (fig5.dat), the
// exploration, nor the science report counts it; each says how many it left out.
TEST_F(Plots, SyntheticRolloutsAreMarkedAndLeftOutOfEveryFigure) {
  domain::RolloutReport fake;
  fake.worker_id = "w";
  fake.synthetic = true;
  fake.summary.cost = 0.25;
  const nlohmann::json marked = domain::to_json(fake);
  ASSERT_TRUE(marked.value("synthetic", false)) << marked.dump();
  EXPECT_TRUE(domain::report_from_json(marked).synthetic);
  EXPECT_TRUE(trial_from_report(0, marked, {}).synthetic);
  domain::RolloutReport real = fake;
  real.synthetic = false;
  EXPECT_FALSE(domain::to_json(real).contains("synthetic")) << "a real report keeps its shape";
  EXPECT_FALSE(trial_from_report(0, domain::to_json(real), {}).synthetic);

  StudyTrials s = synthetic_study(1);
  int marked_count = 0;
  for (auto& t : s.trials) {
    if (t.trial_id % 3 == 0) {
      t.synthetic = true;
      t.cost = 1e6;  // would stand out in any figure that drew it
      ++marked_count;
    }
  }
  const FigureReport report = plot_study(s, dir_);
  EXPECT_TRUE(mentions(report.not_drawn, fmt::format("every figure: {} synthetic rollouts", marked_count)));
  std::ifstream data(dir_ / "fig5.dat");
  std::string line;
  int rows = 0;
  while (std::getline(data, line)) {
    if (line.empty() || line[0] == '#') continue;
    const int rollout = std::stoi(line.substr(0, line.find(' ')));
    EXPECT_NE((rollout - 1) % 3, 0) << "fig5.dat draws synthetic rollout " << rollout;
    ++rows;
  }
  EXPECT_EQ(rows, static_cast<int>(s.trials.size()) - marked_count);

  const StudyTrials explored = exploration_trials(s);
  EXPECT_EQ(explored.synthetic_left_out, marked_count);
  const ScienceReport science = science_report(explored);
  EXPECT_EQ(science.rollouts, static_cast<int>(s.trials.size()) - marked_count);
  EXPECT_EQ(science.synthetic_left_out, marked_count);
  EXPECT_EQ(to_json(science).at("synthetic_left_out").get<int>(), marked_count);
  EXPECT_GT(science.best_cost, 0.0);
  EXPECT_LT(science.best_cost, 1e6) << "the best is a real rollout";
}

}  // namespace
}  // namespace cpgmatch::analysis
