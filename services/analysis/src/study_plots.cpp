// Fig. 5a, 5b and 6 of the paper from one study's trials, and the driver that draws every study figure.
//
// What the data cannot give is said, not drawn badly: a study whose rollouts all fell has no walking cost
// to draw, one of fake rollouts no positive torque for a log axis. Fall costs (13-19) live on their own
// scale, above the walking costs (0.4-6), so that they do not flatten them.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>

#include <fmt/format.h>

#include "cpgmatch/analysis/gnuplot.hpp"
#include "cpgmatch/analysis/parameter_plots.hpp"
#include "cpgmatch/analysis/plots.hpp"

namespace cpgmatch::analysis {

namespace fs = std::filesystem;

namespace {

std::string num(double v) { return gnuplot_number(v); }

// Log axes cannot show zero (a perfect J_periodicity is common): terms below this go to a strip of their own.
constexpr double kLogFloor = 1e-3;
const char* const kFallColour = "#d62728";
const char* const kCostColour = "#1f77b4";

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  int n = 0;
  void add(double v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
    ++n;
  }
  // [lo, hi] with room around it (a single value gets a unit's room).
  std::string padded(double at_least) const {
    const double pad = std::max({0.2 * (hi - lo), at_least, 0.02 * std::abs(hi)});
    return fmt::format("[{}:{}]", num(lo - pad), num(hi + pad));
  }
};

// The x axis every study figure shares: rollouts 1..last with a little room.
std::string rollout_axis(const StudyTrials& s) {
  const int last = s.trials.empty() ? 1 : s.trials.back().trial_id + 1;
  return fmt::format("set xrange [0:{}]\n", last + 1);
}

std::string initial_design_marker(const StudyTrials& s, bool with_label) {
  const int last = s.trials.empty() ? 0 : s.trials.back().trial_id + 1;
  if (s.initial_points <= 0 || s.initial_points >= last) return "";
  const double x = s.initial_points + 0.5;
  std::string out = fmt::format("set arrow from {},graph 0 to {},graph 1 nohead dt 2 lc rgb 'gray40'\n", x, x);
  if (with_label) {
    out += fmt::format("set label 'end of random initial design' at {},graph 0.95 left offset 0.5,0 tc rgb 'gray40'\n", x);
  }
  return out;
}

void write_trials_data(const StudyTrials& s, const fs::path& file) {
  std::ofstream out(file);
  out << "# rollout cost current_min fell feedback distance pitch contact periodicity normalized_torque\n";
  const auto best = current_minimum(s);
  for (std::size_t i = 0; i < s.trials.size(); ++i) {
    const Trial& t = s.trials[i];
    if (!t.ok) continue;  // an evaluation that did not run has no cost to draw
    out << fmt::format("{} {} {} {:d} {} {} {} {} {} {}\n", t.trial_id + 1, num(t.cost), num(best[i]), t.fell,
                       num(t.terms.feedback), num(t.terms.distance), num(t.terms.pitch), num(t.terms.contact),
                       num(t.terms.periodicity), t.fell ? "NaN" : num(t.normalized_torque));
  }
}

FigureScript fig5a(const StudyTrials& s, const fs::path& data) {
  FigureScript f("fig5a");
  Range walk, fall;
  for (const auto& t : s.trials) {
    if (t.ok && std::isfinite(t.cost)) (t.fell ? fall : walk).add(t.cost);
  }
  if (walk.n + fall.n == 0) {
    f.unavailable = "fig5a: no rollout ran, so there is no cost to draw";
    return f;
  }
  const std::string d = gnuplot_quote(data);
  const std::string title = fmt::format("Fig. 5a: cost per rollout and its current minimum (study {}", s.name);
  const std::string walking = fmt::format("{} u 1:($4==0?$2:1/0) w p pt 7 ps 0.6 lc rgb '{}' t 'cost'", d, kCostColour);
  const std::string falls = fmt::format("{} u 1:($4==1?$2:1/0) w p pt 2 ps 1.2 lw 2 lc rgb '{}' t 'fell'", d, kFallColour);
  const std::string minimum = fmt::format("{} u 1:3 w steps lw 2 lc rgb 'black' t 'current minimum'", d);
  f.body = "set datafile missing 'NaN'\nset grid\n" + rollout_axis(s);
  if (fall.n == 0 || walk.n == 0) {  // one kind of rollout: one scale serves
    f.body += fmt::format("set key top right\nset title '{})'\nset xlabel 'rollout'\nset ylabel 'cost J'\n{}plot {}, {}\n",
                          title, initial_design_marker(s, true), fall.n == 0 ? walking : falls, minimum);
    return f;
  }
  // A broken axis: falls in a band of their own above the walking costs, both against the same rollouts.
  f.body += fmt::format(
      "set multiplot title '{}; falls in the band above, on their own scale)'\n"
      "set lmargin at screen 0.08\nset rmargin at screen 0.97\n"
      "set tmargin at screen 0.90\nset bmargin at screen 0.72\n"
      "set yrange {}\nset ytics 2\nset format x ''\nset ylabel 'fell: cost J'\nset key off\n{}"
      "plot {}, {}\n",
      title, fall.padded(0.5), initial_design_marker(s, false), falls, minimum);
  f.body += fmt::format(
      "set tmargin at screen 0.69\nset bmargin at screen 0.10\n"
      "set yrange [{}:{}]\nset ytics autofreq\nset format x '%g'\nset xlabel 'rollout'\nset ylabel 'cost J'\n"
      "set key top right\n{}"
      "plot {}, keyentry w p pt 2 ps 1.2 lw 2 lc rgb '{}' t 'fell (band above)', {}\n",
      num(std::min(0.0, walk.lo)), num(walk.hi + std::max(0.08 * (walk.hi - std::min(0.0, walk.lo)), 0.05)),
      initial_design_marker(s, true), walking, kFallColour, minimum);
  return f;
}

struct TermColumn {
  const char* name;
  int column;  // in fig5.dat
  double CostTerms::*member;
};
const TermColumn kTerms[] = {{"J_feedback", 5, &CostTerms::feedback},
                             {"J_distance", 6, &CostTerms::distance},
                             {"J_pitch", 7, &CostTerms::pitch},
                             {"J_contact", 8, &CostTerms::contact},
                             {"J_periodicity", 9, &CostTerms::periodicity}};

FigureScript fig5b(const StudyTrials& s, const fs::path& data) {
  FigureScript f("fig5b");
  int ran = 0, above = 0, falls = 0;
  for (const auto& t : s.trials) {
    if (!t.ok) continue;
    ++ran;
    falls += t.fell;
    for (const auto& term : kTerms) above += (t.terms.*term.member) >= kLogFloor;
  }
  if (ran == 0) {
    f.unavailable = "fig5b: no rollout ran, so there are no cost terms to draw";
    return f;
  }
  const std::string d = gnuplot_quote(data);
  f.height_px = 700;
  // Three panels on one rollout axis: falls (a strip), the terms on a log axis, the terms below its floor.
  // No `set datafile missing` here: with it gnuplot joins the line across a term that went to the strip
  // below, drawing values that were never there; an undefined point (1/0) must break the line.
  f.body = rollout_axis(s) +
           fmt::format("set multiplot title 'Fig. 5b: cost terms per rollout (study {})'\n"
                       "set lmargin at screen 0.12\nset rmargin at screen 0.80\n",
                       s.name);
  f.body += fmt::format(
      "set tmargin at screen 0.92\nset bmargin at screen 0.87\nset yrange [0:1]\nunset ytics\nset format x ''\n"
      "set grid xtics\nset ylabel 'fell' rotate by 0\nset key off\n{}"
      "plot {} u 1:($4==1?0.5:1/0) w p pt 2 ps 1.2 lw 2 lc rgb '{}' notitle\n",
      falls == 0 ? "set label 'no rollout fell' at graph 0.5,0.5 center tc rgb 'gray40'\n" : "", d, kFallColour);
  f.body += "unset label\nset tmargin at screen 0.85\nset bmargin at screen 0.33\nset grid xtics ytics\n"
            "set ylabel 'cost term' rotate by 90\nset ytics autofreq\nset key outside right top\n";
  if (above == 0) {
    f.notes.push_back(fmt::format("fig5b: no cost term is at or above {}: the log panel is empty, every term is in the strip below", kLogFloor));
    f.body += fmt::format("set yrange [0:1]\nunset ytics\nset label 'no cost term at or above {}' at graph 0.5,0.5 center\n"
                          "plot {} u 1:(1/0) notitle\nunset label\n",
                          kLogFloor, d);
  } else {
    f.body += "set logscale y\nset yrange [*:*]\nplot ";
    for (std::size_t i = 0; i < std::size(kTerms); ++i) {
      f.body += fmt::format("{}{} u 1:(${}>={}?${}:1/0) w lp lc {} pt 7 ps 0.4 t '{}'", i ? ", " : "", i ? "''" : d,
                            kTerms[i].column, kLogFloor, kTerms[i].column, i + 1, kTerms[i].name);
    }
    f.body += "\nunset logscale y\n";
  }
  f.body += fmt::format("set tmargin at screen 0.31\nset bmargin at screen 0.08\nset yrange [0.5:{}.5]\nset ytics (",
                        std::size(kTerms));
  for (std::size_t i = 0; i < std::size(kTerms); ++i) {
    f.body += fmt::format("{}'{}' {}", i ? ", " : "", kTerms[i].name, std::size(kTerms) - i);
  }
  f.body += fmt::format(")\nset format x '%g'\nset xlabel 'rollout'\nset ylabel 'below {}' rotate by 90\nset key off\nplot ",
                        kLogFloor);
  for (std::size_t i = 0; i < std::size(kTerms); ++i) {
    f.body += fmt::format("{}{} u 1:(${}<{}?{}:1/0) w p pt 5 ps 0.5 lc {} notitle", i ? ", " : "", i ? "''" : d,
                          kTerms[i].column, kLogFloor, std::size(kTerms) - i, i + 1);
  }
  f.body += "\n";
  return f;
}

// Fig. 6: rollouts sorted by cost (best first); torque of those that walked, a shaded bar for each fall.
FigureScript fig6(const StudyTrials& s, const fs::path& data) {
  FigureScript f("fig6");
  std::vector<const Trial*> ran;
  for (const auto& t : s.trials) {
    if (t.ok && std::isfinite(t.cost)) ran.push_back(&t);
  }
  if (ran.empty()) {
    f.unavailable = "fig6: no rollout ran, so there is nothing to sort by cost";
    return f;
  }
  std::stable_sort(ran.begin(), ran.end(), [](const Trial* a, const Trial* b) { return a->cost < b->cost; });
  std::string falls;
  int positive = 0, walked_without = 0, fell = 0;
  {
    std::ofstream out(data);
    out << "# rank_by_cost rollout cost normalized_torque(walked, > 0)\n";
    for (std::size_t i = 0; i < ran.size(); ++i) {
      const Trial& t = *ran[i];
      const bool drawn = !t.fell && t.normalized_torque > 0.0 && std::isfinite(t.normalized_torque);
      positive += drawn;
      walked_without += !t.fell && !drawn;
      fell += t.fell;
      out << fmt::format("{} {} {} {}\n", i + 1, t.trial_id + 1, num(t.cost), drawn ? num(t.normalized_torque) : "NaN");
      if (t.fell) {
        falls += fmt::format("set object rect from {},graph 0 to {},graph 1 fc rgb '{}' fs transparent solid 0.25 noborder behind\n",
                             i + 0.5, i + 1.5, kFallColour);
      }
    }
  }
  const std::string d = gnuplot_quote(data);
  f.body = fmt::format("set datafile missing 'NaN'\nset grid\nset key top left\nset xrange [0.5:{}.5]\n"
                       "set xlabel 'rollouts sorted by cost (1 = best)'\nset ylabel 'normalised torque, N m / (m/s)'\n{}",
                       ran.size(), falls);
  const std::string fell_key = fmt::format("keyentry w boxes fs transparent solid 0.25 lc rgb '{}' t 'fell'", kFallColour);
  if (positive == 0) {
    f.notes.push_back(
        fmt::format("fig6: none of the {} rollouts that walked has a positive normalised torque (a log axis needs > 0): "
                    "only the falls are drawn",
                    static_cast<int>(ran.size()) - fell));
    f.body += fmt::format(
        "set title 'Fig. 6: rollouts sorted by cost (shaded: falls); no positive torque to draw'\nset yrange [0:1]\nunset ytics\n"
        "set label 'no rollout that walked has a positive normalised torque' at graph 0.5,0.5 center\n"
        "plot {} u 1:(1/0) notitle, {}\n",
        d, fell_key);
    return f;
  }
  if (walked_without > 0) {
    f.notes.push_back(fmt::format("fig6: {} rollout(s) that walked have no positive normalised torque and are not on the log axis",
                                  walked_without));
  }
  f.body += fmt::format(
      "set logscale y\n"  // torques of bad gaits are orders of magnitude above good ones
      "set title 'Fig. 6: normalised torque of rollouts sorted by cost (log scale; shaded: falls, no torque)'\n"
      "plot {} u 1:4 w p pt 7 ps 0.6 lc rgb '{}' t 'normalised torque (eq. 1)', '' u 1:4 smooth bezier lw 2 lc rgb 'black' "
      "t 'trend', {}\n",
      d, kCostColour, fell_key);
  return f;
}

// Beside Fig. 6: what the motors drew (energy.hpp), per weight and metre, of the rollouts that walked, in the
// same order (sorted by cost, falls shaded). A store from before energy has none: then it is not drawn.
FigureScript fig6_cot(const StudyTrials& s, const fs::path& data) {
  FigureScript f("fig6_cot");
  std::vector<const Trial*> ran;
  for (const auto& t : s.trials) {
    if (t.ok && std::isfinite(t.cost)) ran.push_back(&t);
  }
  std::stable_sort(ran.begin(), ran.end(), [](const Trial* a, const Trial* b) { return a->cost < b->cost; });
  const bool has_energy = std::any_of(ran.begin(), ran.end(), [](const Trial* t) {
    return !t->fell && std::isfinite(t->energy.electrical_cost_of_transport) && t->energy.electrical_cost_of_transport > 0.0;
  });
  if (!has_energy) {
    f.unavailable = "fig6_cot: no rollout that walked has an electrical cost of transport (a store from before energy, "
                    "or a plant without a motor model)";
    return f;
  }
  std::string falls;
  {
    std::ofstream out(data);
    out << "# rank_by_cost rollout cost electrical_cost_of_transport(walked)\n";
    for (std::size_t i = 0; i < ran.size(); ++i) {
      const Trial& t = *ran[i];
      const double cot = t.energy.electrical_cost_of_transport;
      out << fmt::format("{} {} {} {}\n", i + 1, t.trial_id + 1, num(t.cost),
                         !t.fell && cot > 0.0 && std::isfinite(cot) ? num(cot) : "NaN");
      if (t.fell) {
        falls += fmt::format("set object rect from {},graph 0 to {},graph 1 fc rgb '{}' fs transparent solid 0.25 noborder behind\n",
                             i + 0.5, i + 1.5, kFallColour);
      }
    }
  }
  f.body = fmt::format(
      "set datafile missing 'NaN'\nset grid\nset key top left\nset xrange [0.5:{}.5]\nset logscale y\n"
      "set title 'Beside Fig. 6: electrical cost of transport of rollouts sorted by cost (log scale; shaded: falls)'\n"
      "set xlabel 'rollouts sorted by cost (1 = best)'\nset ylabel 'electrical cost of transport E / (m g d)'\n{}"
      "plot {} u 1:4 w p pt 7 ps 0.6 lc rgb '{}' t 'electrical cost of transport (DC-motor model)', '' u 1:4 smooth bezier "
      "lw 2 lc rgb 'black' t 'trend', keyentry w boxes fs transparent solid 0.25 lc rgb '{}' t 'fell'\n",
      ran.size(), falls, gnuplot_quote(data), kCostColour, kFallColour);
  return f;
}

}  // namespace

std::vector<double> current_minimum(const StudyTrials& s) {
  std::vector<double> out;
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : s.trials) {
    if (t.ok && std::isfinite(t.cost)) best = std::min(best, t.cost);
    out.push_back(std::isfinite(best) ? best : std::nan(""));
  }
  return out;
}

void draw_figure(const fs::path& dir, const FigureScript& figure, FigureReport& report) {
  for (const auto& note : figure.notes) report.not_drawn.push_back(note);
  if (!figure.unavailable.empty()) {
    report.not_drawn.push_back(figure.unavailable);
    return;
  }
  try {
    for (const auto& file : render_figure(dir, figure.stem, figure.body, figure.width_px, figure.height_px)) {
      report.files.push_back(file);
    }
  } catch (const PlotError& e) {
    report.failed.push_back(e.what());
  }
}

FigureReport plot_study(const StudyTrials& given, const fs::path& out_dir) {
  if (!gnuplot_available()) throw PlotError("gnuplot not found on PATH: no figures (install gnuplot-nox)");
  // Synthetic rollouts (--fake-rollout-ms) measured no gait: no figure draws them, whoever calls this.
  StudyTrials s = given;
  s.synthetic_left_out += static_cast<int>(std::erase_if(s.trials, [](const Trial& t) { return t.synthetic; }));
  const fs::path dir = fs::absolute(out_dir);
  fs::create_directories(dir);
  const fs::path trials = dir / "fig5.dat";
  write_trials_data(s, trials);
  FigureReport report;
  if (s.synthetic_left_out > 0) {
    report.not_drawn.push_back(fmt::format("every figure: {} synthetic rollout{} (--fake-rollout-ms, no gait) left out",
                                           s.synthetic_left_out, s.synthetic_left_out == 1 ? "" : "s"));
  }
  draw_figure(dir, fig5a(s, trials), report);
  draw_figure(dir, fig5b(s, trials), report);
  draw_figure(dir, fig6(s, dir / "fig6.dat"), report);
  draw_figure(dir, fig6_cot(s, dir / "fig6_cot.dat"), report);
  for (const auto& figure : parameter_figures(s, dir)) draw_figure(dir, figure, report);
  return report;
}

}  // namespace cpgmatch::analysis
