#include "cpgmatch/analysis/parameter_plots.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>

#include <fmt/format.h>

#include "cpgmatch/analysis/gnuplot.hpp"
#include "cpgmatch/analysis/surrogate.hpp"

namespace cpgmatch::analysis {

namespace fs = std::filesystem;

namespace {

std::string num(double v) { return gnuplot_number(v); }

const char* const kFallColour = "#d62728";
// Light to dark: early to late rollouts (slices), high to low cost (parallel coordinates: the best stand out).
const char* const kPalette = "set palette defined (0 '#c6dbef', 1 '#08306b')\n";

// A round tic step giving about five tics over span.
double tic_step(double span) {
  if (!(span > 0.0)) return 1.0;
  const double raw = span / 5.0, decade = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0}) {
    if (m * decade >= raw) return m * decade;
  }
  return 10.0 * decade;
}

// The cost axis of a figure with falls: walking costs to scale, falls in a band above (not to scale).
struct CostAxis {
  bool walking = false, falls = false;
  double lo = 0.0, hi = 1.0;  // the axis' range for the walking costs (lo: at most 0)
  double lowest = 0.0;        // the lowest walking cost
  double fall_y = 0.0;        // where falls are drawn
  double top = 1.0;           // the axis' end

  explicit CostAxis(const std::vector<const Trial*>& ran) {
    double wlo = INFINITY, whi = -INFINITY, flo = INFINITY, fhi = -INFINITY;
    for (const Trial* t : ran) {
      if (t->fell) {
        falls = true;
        flo = std::min(flo, t->cost);
        fhi = std::max(fhi, t->cost);
      } else {
        walking = true;
        wlo = std::min(wlo, t->cost);
        whi = std::max(whi, t->cost);
      }
    }
    if (!walking) {  // only falls: they are the scale
      wlo = flo;
      whi = fhi;
    }
    lowest = wlo;
    lo = std::min(0.0, wlo);
    hi = whi > lo ? whi : lo + 1.0;
    const double span = hi - lo;
    fall_y = walking && falls ? hi + 0.15 * span : 0.0;
    top = walking && falls ? hi + 0.25 * span : hi + 0.05 * span;
  }
  bool band() const { return walking && falls; }
  // A trial's y on this axis.
  double y(const Trial& t) const { return band() && t.fell ? fall_y : t.cost; }
  // ytics: to scale up to the walking costs, then one labelled tic for the band.
  std::string tics() const {
    const double step = tic_step(hi - lo);
    std::string s = fmt::format("set yrange [{}:{}]\nset ytics {},{},{}\n", num(lo), num(top), num(lo), num(step), num(hi));
    if (band()) {
      s += fmt::format("set ytics add ('fell' {})\nset arrow from graph 0,first {} to graph 1,first {} nohead dt 3 lc rgb 'gray50'\n",
                       num(fall_y), num(hi + 0.07 * (hi - lo)), num(hi + 0.07 * (hi - lo)));
    }
    return s;
  }
};

std::vector<const Trial*> rollouts_that_ran(const StudyTrials& s) {
  std::vector<const Trial*> ran;
  for (const auto& t : s.trials) {
    if (t.ok && std::isfinite(t.cost)) ran.push_back(&t);
  }
  return ran;
}

// A parameter's axis label: its name and, when it has one, its unit (the study's space's: a robot's own).
std::string axis_label(const SearchDimension& d, const char* separator) {
  return d.unit.empty() || d.unit == "1" ? d.name : fmt::format("{}{}({})", d.name, separator, d.unit);
}

double param(const Trial& t, const SearchDimension& d) {
  const auto it = t.params.find(d.name);
  return it == t.params.end() ? std::nan("") : it->second;
}

FigureScript slices(const StudyTrials& s, const std::vector<SearchDimension>& dims, const std::vector<const Trial*>& ran,
                    const std::optional<SurrogateView>& model, const std::string& no_model, const fs::path& dir) {
  FigureScript f("param_slices");
  const CostAxis axis(ran);
  const fs::path data = dir / "param_slices.dat", pd = dir / "param_pd.dat";
  {
    std::ofstream out(data);
    out << "# rollout fell y(cost; falls in the band) cost";
    for (const auto& d : dims) out << ' ' << d.name;
    out << '\n';
    for (const Trial* t : ran) {
      out << fmt::format("{} {:d} {} {}", t->trial_id + 1, t->fell, num(axis.y(*t)), num(t->cost));
      for (const auto& d : dims) out << ' ' << num(param(*t, d));
      out << '\n';
    }
  }
  if (model) {
    // One block per parameter (gnuplot's `index`); where the model's cost reaches the fall band it is not drawn.
    std::ofstream out(pd);
    for (const auto& curve : model->partial_dependence) {
      out << "# " << curve.name << ": x partial_dependence_cost\n";
      for (std::size_t i = 0; i < curve.x.size(); ++i) {
        const bool shown = !axis.band() || curve.cost[i] <= axis.hi + 0.05 * (axis.hi - axis.lo);
        out << num(curve.x[i]) << ' ' << (shown ? num(curve.cost[i]) : "NaN") << '\n';
      }
      out << "\n\n";
    }
  } else {
    f.notes.push_back("param_slices: no partial dependence line: " + no_model);
  }
  const int cols = std::min<int>(3, static_cast<int>(dims.size()));
  const int rows = (static_cast<int>(dims.size()) + cols - 1) / cols;
  f.width_px = 1200;
  f.height_px = 120 + 300 * rows;
  const int last = s.trials.empty() ? 1 : s.trials.back().trial_id + 1;
  f.body = fmt::format(
      "set datafile missing 'NaN'\nset grid\n{}set cbrange [1:{}]\nunset colorbox\nset key off\n"
      "set multiplot layout {},{} title \"Parameter slices (study {}): cost of each rollout against each parameter\\n"
      "dot colour: light = early, dark = late rollout; {}{}\"\n{}",
      kPalette, std::max(2, last), rows, cols, s.name, axis.band() ? "red x: fell (band at the top, not to scale); " : "",
      model ? "black line: the GP's partial dependence" : "no model line", axis.tics());
  const std::string d = gnuplot_quote(data);
  for (std::size_t j = 0; j < dims.size(); ++j) {
    const int c = static_cast<int>(j) + 5;  // the parameter's column
    f.body += fmt::format("set xlabel '{}'\nset xrange [{}:{}]\nset ylabel '{}'\n", axis_label(dims[j], " "), num(dims[j].low),
                          num(dims[j].high), j % static_cast<std::size_t>(cols) == 0 ? "cost J" : "");
    if (dims[j].log_scale) f.body += "set logscale x\n";
    f.body += fmt::format("plot {} u {}:($2==0?$3:1/0):1 w p pt 7 ps 0.7 lc palette, '' u {}:($2==1?$3:1/0) w p pt 2 ps 1 lw 2 lc rgb '{}'",
                          d, c, c, kFallColour);
    if (model) f.body += fmt::format(", {} index {} u 1:2 w l lw 2 lc rgb 'black'", gnuplot_quote(pd), j);
    f.body += "\nunset logscale x\n";
  }
  f.body += "unset multiplot\n";
  return f;
}

FigureScript importance(const StudyTrials& s, const std::optional<SurrogateView>& model, const std::string& no_model,
                        const fs::path& dir) {
  FigureScript f("param_importance");
  if (!model) {
    f.unavailable = "param_importance: " + no_model;
    return f;
  }
  std::vector<ParameterImportance> sorted = model->importance;
  std::stable_sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) { return a.relevance > b.relevance; });
  const fs::path data = dir / "param_importance.dat";
  {
    std::ofstream out(data);
    out << "# parameter relevance(1/l normalised) length_scale(search ranges)\n";
    for (const auto& p : sorted) out << p.name << ' ' << num(p.relevance) << ' ' << num(p.length_scale) << '\n';
  }
  const std::size_t n = sorted.size();
  f.width_px = 900;
  f.height_px = 200 + 50 * static_cast<int>(n);
  f.body = fmt::format(
      "set title \"Parameter importance (study {}): relevance 1/l of the GP's length scale l per parameter, normalised\\n{}\"\n"
      "set xlabel 'relevance (sums to 1); label: share and length scale l in search ranges'\nset xrange [0:{}]\n"
      "set yrange [-0.6:{}]\nset grid xtics\nset key off\nset style fill solid 0.7 noborder\n"
      "plot {} u ($2/2):({}-$0):($2/2):(0.35):ytic(1) w boxxyerror lc rgb '#1f77b4', "
      "'' u 2:({}-$0):(sprintf('%.1f%%, l = %.3g', 100*$2, $3)) w labels left offset 0.5,0\n",
      s.name, model->source, num(std::min(1.0, sorted.front().relevance * 1.45 + 0.05)), num(n - 0.4), gnuplot_quote(data),
      n - 1, n - 1);
  return f;
}

FigureScript parallel(const StudyTrials& s, const std::vector<SearchDimension>& dims, std::vector<const Trial*> ran,
                      const fs::path& dir) {
  FigureScript f("param_parallel");
  const CostAxis axis(ran);
  // Falls first, then worst to best, so that the best lines are drawn last, on top.
  std::stable_sort(ran.begin(), ran.end(), [](const Trial* a, const Trial* b) {
    return a->fell != b->fell ? a->fell : a->cost > b->cost;
  });
  // Every plot clause of `parallelaxes` is one axis, so falls and walking rollouts share one set of axes
  // and differ by colour only: the palette runs dark (low cost) to light over the walking costs, and its
  // last tenth is red, where falls are put. Log colours when the costs allow it: most gaits of a study
  // cost little, a few much more, and a linear scale painted nearly all of them the same dark blue.
  // Walking costs fill the palette's lowest `walk_share`; falls (when there are walking ones too) sit at
  // its red top, apart from the lightest blue so the worst gait is never painted as a fall.
  const double walk_share = axis.band() ? 0.88 : 1.0;
  const bool log_colour = axis.lowest > 0.0 && axis.hi > axis.lowest;
  const double cb_top = log_colour ? std::exp(std::log(axis.lowest) + (std::log(axis.hi) - std::log(axis.lowest)) / walk_share)
                                   : axis.lowest + (axis.hi - axis.lowest) / walk_share;
  const fs::path data = dir / "param_parallel.dat";
  {
    std::ofstream out(data);
    out << "#";
    for (const auto& d : dims) out << ' ' << d.name;
    out << " y(cost; falls in the band) colour(cost; falls: the red end) cost rollout\n";
    for (const Trial* t : ran) {
      for (const auto& d : dims) out << num(param(*t, d)) << ' ';
      out << num(axis.y(*t)) << ' ' << num(t->fell && axis.band() ? cb_top : t->cost) << ' ' << num(t->cost) << ' '
          << t->trial_id + 1 << '\n';
    }
  }
  const std::size_t n = dims.size();
  f.width_px = 1200;
  f.height_px = 650;
  f.body = fmt::format(
      "set palette defined {}\n{}set cbrange [{}:{}]\nset cblabel 'cost J{}'\n"
      "set title \"Parallel coordinates (study {}): every rollout from its parameters to its cost\\n"
      "colour: cost, dark = low{}\"\n"
      // Room below the axes for a second label line (a parameter's unit).
      "set border 0\nunset ytics\nset key off\nset bmargin 4\nset xrange [0.8:{}.2]\nset xtics (",
      axis.band() ? fmt::format("(0 '#08306b', 0.88 '#c6dbef', 0.9 '{}', 1 '{}')", kFallColour, kFallColour)
                  : std::string("(0 '#08306b', 1 '#c6dbef')"),
      log_colour ? "set logscale cb\n" : "", num(axis.lowest), num(cb_top),
      fmt::format("{}{}", log_colour ? ", log colour scale" : "", axis.band() ? "; red: fell" : ""), s.name,
      axis.band() ? "; red: fell (on the cost axis at the top, not to scale)" : "", n + 1);
  // The unit under the name (double quotes: gnuplot reads \n in them as a line break).
  for (std::size_t j = 0; j < n; ++j) f.body += fmt::format("\"{}\" {}, ", axis_label(dims[j], "\\n"), j + 1);
  f.body += fmt::format("'cost J' {})\n", n + 1);
  if (log_colour) {  // gnuplot's log tics are decades: too few over one or two of them
    std::string tics;
    for (double decade = std::pow(10.0, std::floor(std::log10(axis.lowest))); decade <= axis.hi; decade *= 10.0) {
      for (double m : {1.0, 2.0, 5.0}) {
        if (m * decade >= axis.lowest && m * decade <= axis.hi) tics += fmt::format("{}{}", tics.empty() ? "" : ", ", num(m * decade));
      }
    }
    if (!tics.empty()) f.body += fmt::format("set cbtics ({})\n", tics);
  }
  for (std::size_t j = 0; j < n; ++j) {
    f.body += fmt::format("set paxis {} range [{}:{}]\nset paxis {} tics\n", j + 1, num(dims[j].low), num(dims[j].high), j + 1);
  }
  f.body += fmt::format("set paxis {} range [{}:{}]\nset paxis {} tics {},{},{}\n", n + 1, num(axis.lo), num(axis.top), n + 1,
                        num(axis.lo), num(tic_step(axis.hi - axis.lo)), num(axis.hi));
  if (axis.band()) f.body += fmt::format("set paxis {} tics add ('fell' {})\n", n + 1, num(axis.fall_y));
  f.body += fmt::format("plot {} u 1:{} w parallelaxes lw 1 lc palette", gnuplot_quote(data), n + 2);
  for (std::size_t j = 1; j <= n; ++j) f.body += fmt::format(", '' u {} w parallelaxes", j + 1);
  f.body += "\n";
  return f;
}

}  // namespace

std::vector<FigureScript> parameter_figures(const StudyTrials& s, const fs::path& dir) {
  const std::vector<SearchDimension> dims = search_dimensions(s);
  const std::vector<const Trial*> ran = rollouts_that_ran(s);
  std::string no_model;
  const std::optional<SurrogateView> model = surrogate_view(s, &no_model);
  std::vector<FigureScript> out;
  if (dims.empty() || ran.empty()) {
    const std::string why = dims.empty() ? "the study has no search space" : "no rollout ran";
    for (const char* stem : {"param_slices", "param_importance", "param_parallel"}) {
      FigureScript f(stem);
      f.unavailable = fmt::format("{}: {}", stem, why);
      out.push_back(f);
    }
    return out;
  }
  out.push_back(slices(s, dims, ran, model, no_model, dir));
  out.push_back(importance(s, model, no_model, dir));
  out.push_back(parallel(s, dims, ran, dir));
  return out;
}

}  // namespace cpgmatch::analysis
