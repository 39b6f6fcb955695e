// The figures are real files: PNGs with the PNG signature, SVGs with drawn data.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "cpgmatch/analysis/gnuplot.hpp"
#include "cpgmatch/analysis/plots.hpp"
#include "cpgmatch/analysis/replicates.hpp"
#include "cpgmatch/analysis/science_report.hpp"

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
  const auto files = plot_study(synthetic_study(0), dir_);
  EXPECT_EQ(files.size(), 8u);
  for (const char* stem : {"fig5a", "fig5b", "fig6", "fig6_cot"}) expect_figure(dir_, stem);
}

TEST_F(Plots, AStudyWithoutEnergyDataDrawsFig6Alone) {
  StudyTrials s = synthetic_study(0);
  for (auto& t : s.trials) t.energy = EnergyMeasures{};
  const auto files = plot_study(s, dir_);
  EXPECT_EQ(files.size(), 6u);
  EXPECT_FALSE(fs::exists(dir_ / "fig6_cot.png"));
}

TEST_F(Plots, TraceFigure) {
  fs::create_directories(dir_);
  const fs::path csv = dir_ / "trace.csv";
  {
    std::ofstream out(csv);
    out << "time_s,x_m";
    for (const char* leg : {"FL", "FR", "HL", "HR"}) {
      for (const char* q : {"_phase", "_hip_target_rad", "_hip_rad", "_knee_target_rad", "_knee_rad", "_contact", "_ltd",
                            "_etd", "_eto", "_lto"}) {
        out << ',' << leg << q;
      }
    }
    out << '\n';
    for (int k = 0; k < 3000; ++k) {
      const double t = 0.002 * k, phase = std::fmod(6.2831853 * t, 6.2831853);
      out << t << ',' << 0.3 * t;
      for (int leg = 0; leg < 4; ++leg) {
        const bool stance = std::sin(6.2831853 * t + leg) > 0;
        out << ',' << phase << ',' << 0.2 * std::sin(phase) << ',' << 0.19 * std::sin(phase) << ',' << 0.5 << ',' << 0.48
            << ',' << stance << ',' << (k % 200 < 20) << ',' << (k % 300 < 10) << ',' << (k % 250 < 30) << ',' << 0;
      }
      out << '\n';
    }
  }
  const auto files = plot_trace(csv, dir_, 4.0);
  EXPECT_EQ(files.size(), 2u);
  expect_figure(dir_, "fig4");
}

TEST_F(Plots, TraceWithoutTheColumnsIsAClearError) {
  fs::create_directories(dir_);
  std::ofstream(dir_ / "bad.csv") << "time_s,foo\n0,1\n";
  try {
    plot_trace(dir_ / "bad.csv", dir_);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("FL_phase"), std::string::npos) << e.what();
  }
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
