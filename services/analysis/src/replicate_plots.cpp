// The replicate figures: how much of a single study's curve is the seed.
#include <cmath>
#include <fstream>

#include <fmt/format.h>

#include "cpgmatch/analysis/gnuplot.hpp"
#include "cpgmatch/analysis/plots.hpp"
#include "cpgmatch/analysis/statistics.hpp"

namespace cpgmatch::analysis {

namespace fs = std::filesystem;

namespace {

std::string num(double v) { return gnuplot_number(v); }

}  // namespace

FigureFiles plot_replicates(const std::vector<StudyTrials>& studies, const ReplicateSummary& summary,
                            const fs::path& out_dir) {
  const fs::path dir = fs::absolute(out_dir);
  fs::create_directories(dir);
  FigureFiles files;

  // Current minimum: one column per seed, then the mean over the seeds that have a value there.
  std::vector<std::vector<double>> curves;
  std::size_t length = 0;
  for (const auto& s : studies) {
    curves.push_back(current_minimum(s));
    length = std::max(length, curves.back().size());
  }
  const fs::path minima = dir / "replicates_min_cost.dat";
  {
    std::ofstream out(minima);
    out << "# rollout current_min(seed 1..N) mean\n";
    for (std::size_t i = 0; i < length; ++i) {
      std::vector<double> here;
      out << i + 1;
      for (const auto& c : curves) {
        const double v = i < c.size() ? c[i] : std::nan("");
        out << ' ' << num(v);
        if (std::isfinite(v)) here.push_back(v);
      }
      out << ' ' << num(mean(here)) << '\n';
    }
  }
  std::string plot = fmt::format(
      "set datafile missing 'NaN'\nset grid\nset key top right\n"
      "set title 'Current minimum of the cost over rollouts: {} replicates (thin) and their mean (thick)'\n"
      "set xlabel 'rollout'\nset ylabel 'current minimum cost'\nplot ",
      studies.size());
  for (std::size_t k = 0; k < studies.size(); ++k) {
    plot += fmt::format("{} u 1:{} w steps lw 1 lc rgb 'gray60' t '{}', ", k == 0 ? gnuplot_quote(minima) : "''",
                        k + 2, k == 0 ? "replicates" : "");
  }
  plot += fmt::format("{} u 1:{} w steps lw 3 lc rgb 'black' t 'mean'\n", studies.empty() ? gnuplot_quote(minima) : "''",
                      studies.size() + 2);
  for (const auto& f : render_figure(dir, "replicates_min_cost", plot, 1000, 600)) files.push_back(f);

  // J_feedback window means: mean ± sd over seeds per window.
  const fs::path windows = dir / "replicates_feedback.dat";
  {
    std::ofstream out(windows);
    out << "# window_index label mean sd\n";
    const auto& first = summary.reports.empty() ? nlohmann::json::object() : summary.reports.front();
    const auto& ws = first.value("windows", nlohmann::json::array());
    for (std::size_t i = 0; i < ws.size(); ++i) {
      const auto it = summary.stats.find(fmt::format("windows.{}.feedback_mean", i));
      if (it == summary.stats.end()) continue;
      out << fmt::format("{} {}-{} {} {}\n", i, ws[i]["first"].get<int>(), ws[i]["last"].get<int>(), num(it->second.mean),
                         num(std::isfinite(it->second.sd) ? it->second.sd : 0.0));
    }
  }
  const std::string bars = fmt::format(
      "set datafile missing 'NaN'\nset grid\nset key off\nset style fill solid 0.5\nset boxwidth 0.6\n"
      "set title 'Mean J_feedback of the non-fallen rollouts per window: mean ± sd over {} replicates'\n"
      "set xlabel 'rollouts'\nset ylabel 'J_feedback'\nset yrange [0:*]\nset offsets 0.5,0.5,0,0\n"
      "plot {} u 1:3:xtic(2) w boxes lc rgb '#1f77b4', '' u 1:3:4 w yerrorbars pt 7 lc rgb 'black'\n",
      studies.size(), gnuplot_quote(windows));
  for (const auto& f : render_figure(dir, "replicates_feedback", bars, 800, 600)) files.push_back(f);
  return files;
}

}  // namespace cpgmatch::analysis
