// Fig. 5a, 5b and 6 of the paper from one study's trials.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>

#include <fmt/format.h>

#include "cpgmatch/analysis/gnuplot.hpp"
#include "cpgmatch/analysis/plots.hpp"

namespace cpgmatch::analysis {

namespace fs = std::filesystem;

namespace {

std::string num(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : "NaN"; }

// Log axes cannot show zero (a perfect J_periodicity is common): terms are drawn at least at this.
constexpr double kLogFloor = 1e-3;

void write_trials_data(const StudyTrials& s, const fs::path& file) {
  std::ofstream out(file);
  out << "# rollout cost current_min fell feedback distance pitch contact periodicity normalized_torque\n";
  const auto best = current_minimum(s);
  for (std::size_t i = 0; i < s.trials.size(); ++i) {
    const Trial& t = s.trials[i];
    if (!t.ok) continue;  // an evaluation that did not run has no cost to draw
    const auto floor = [](double v) { return std::isfinite(v) ? std::max(v, kLogFloor) : v; };
    out << fmt::format("{} {} {} {:d} {} {} {} {} {} {}\n", t.trial_id + 1, num(t.cost), num(best[i]), t.fell,
                       num(floor(t.terms.feedback)), num(floor(t.terms.distance)), num(floor(t.terms.pitch)),
                       num(floor(t.terms.contact)), num(floor(t.terms.periodicity)),
                       t.fell ? "NaN" : num(t.normalized_torque));
  }
}

std::string fig5a(const StudyTrials& s, const fs::path& data) {
  const std::string d = gnuplot_quote(data);
  return fmt::format(
      "set datafile missing 'NaN'\nset grid\nset key top right\n"
      "set title 'Fig. 5a: cost per rollout and its current minimum (study {})'\n"
      "set xlabel 'rollout'\nset ylabel 'cost J'\n"
      "set arrow from {},graph 0 to {},graph 1 nohead dt 2 lc rgb 'gray40'\n"
      "set label 'end of random initial design' at {},graph 0.95 left offset 0.5,0 tc rgb 'gray40'\n"
      "plot {} u 1:($4==0?$2:1/0) w p pt 7 ps 0.6 lc rgb '#1f77b4' t 'cost', "
      "'' u 1:($4==1?$2:1/0) w p pt 2 ps 1.2 lw 2 lc rgb '#d62728' t 'fell', "
      "'' u 1:3 w steps lw 2 lc rgb 'black' t 'current minimum'",
      s.name, s.initial_points + 0.5, s.initial_points + 0.5, s.initial_points + 0.5, d);
}

std::string fig5b(const fs::path& data) {
  const std::string d = gnuplot_quote(data);
  return fmt::format(
      "set datafile missing 'NaN'\nset grid\nset key outside right\nset logscale y\n"
      "set title 'Fig. 5b: cost terms per rollout (log scale; values below {} drawn at {})'\n"
      "set xlabel 'rollout'\nset ylabel 'cost term'\n"
      "plot {} u 1:5 w lp pt 7 ps 0.4 t 'J_feedback', '' u 1:6 w lp pt 7 ps 0.4 t 'J_distance', "
      "'' u 1:7 w lp pt 7 ps 0.4 t 'J_pitch', '' u 1:8 w lp pt 7 ps 0.4 t 'J_contact', "
      "'' u 1:9 w lp pt 7 ps 0.4 t 'J_periodicity', "
      "'' u 1:($4==1?{}:1/0) w p pt 2 ps 1.2 lc rgb '#d62728' t 'fell'",
      kLogFloor, kLogFloor, d, kLogFloor);
}

// Rollouts sorted by cost (best first) into `data`: rank, rollout, cost, eq. 1 and electrical cost of
// transport (NaN for falls). Returns the gnuplot objects that shade each fall's bar.
std::string write_sorted_by_cost(const StudyTrials& s, const fs::path& data) {
  std::vector<const Trial*> ran;
  for (const auto& t : s.trials) {
    if (t.ok && std::isfinite(t.cost)) ran.push_back(&t);
  }
  std::stable_sort(ran.begin(), ran.end(), [](const Trial* a, const Trial* b) { return a->cost < b->cost; });
  std::string falls;
  std::ofstream out(data);
  out << "# rank_by_cost rollout cost normalized_torque electrical_cost_of_transport (both NaN for falls)\n";
  for (std::size_t i = 0; i < ran.size(); ++i) {
    const Trial& t = *ran[i];
    out << fmt::format("{} {} {} {} {}\n", i + 1, t.trial_id + 1, num(t.cost), t.fell ? "NaN" : num(t.normalized_torque),
                       t.fell ? "NaN" : num(t.energy.electrical_cost_of_transport));
    if (t.fell) {
      falls += fmt::format("set object rect from {},graph 0 to {},graph 1 fc rgb '#d62728' fs transparent solid 0.25 noborder behind\n",
                           i + 0.5, i + 1.5);
    }
  }
  return falls;
}

// Fig. 6 and its energy companion: one column of the sorted data over the rank, with a trend and the falls.
struct SortedFigure {
  int column;
  std::string title, ylabel, key;
};
std::string sorted_by_cost_figure(const SortedFigure& f, const std::string& falls, const fs::path& data) {
  return fmt::format(
      "set datafile missing 'NaN'\nset grid\nset key top left\n"
      "set logscale y\n"  // bad gaits spend orders of magnitude more than good ones
      "set title '{}'\n"
      "set xlabel 'rollouts sorted by cost (1 = best)'\nset ylabel '{}'\n"
      "{}plot {} u 1:{} w p pt 7 ps 0.6 lc rgb '#1f77b4' t '{}', "
      "'' u 1:{} smooth bezier lw 2 lc rgb 'black' t 'trend', "
      "keyentry w boxes fs transparent solid 0.25 lc rgb '#d62728' t 'fell'",
      f.title, f.ylabel, falls, gnuplot_quote(data), f.column, f.key, f.column);
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

FigureFiles plot_study(const StudyTrials& s, const fs::path& out_dir) {
  const fs::path dir = fs::absolute(out_dir);
  fs::create_directories(dir);
  const fs::path trials = dir / "fig5.dat", sorted = dir / "fig6.dat";
  write_trials_data(s, trials);
  FigureFiles files;
  for (const auto& f : render_figure(dir, "fig5a", fig5a(s, trials), 1000, 600)) files.push_back(f);
  for (const auto& f : render_figure(dir, "fig5b", fig5b(trials), 1000, 600)) files.push_back(f);
  const std::string falls = write_sorted_by_cost(s, sorted);
  const SortedFigure fig6{4, "Fig. 6: normalised torque of rollouts sorted by cost (log scale; shaded: falls, no torque)",
                          "normalised torque, N m / (m/s)", "normalised torque (eq. 1)"};
  for (const auto& f : render_figure(dir, "fig6", sorted_by_cost_figure(fig6, falls, sorted), 1000, 600)) files.push_back(f);
  // Beside Fig. 6: what the motors drew (energy.hpp), per weight and metre, for the same order. A store from
  // before energy has none to draw (gnuplot refuses a plot without a point).
  const bool has_energy = std::any_of(s.trials.begin(), s.trials.end(), [](const Trial& t) {
    return t.walked() && std::isfinite(t.energy.electrical_cost_of_transport);
  });
  if (!has_energy) return files;
  const SortedFigure cot{5, "Beside Fig. 6: electrical cost of transport of rollouts sorted by cost (log scale; shaded: falls)",
                         "electrical cost of transport E / (m g d)", "electrical cost of transport (DC-motor model)"};
  for (const auto& f : render_figure(dir, "fig6_cot", sorted_by_cost_figure(cot, falls, sorted), 1000, 600)) files.push_back(f);
  return files;
}

}  // namespace cpgmatch::analysis
