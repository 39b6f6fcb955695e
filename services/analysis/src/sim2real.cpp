#include "cpgmatch/analysis/sim2real.hpp"

#include <cmath>
#include <fstream>
#include <functional>

#include <fmt/format.h>

#include "cpgmatch/analysis/gnuplot.hpp"
#include "cpgmatch/analysis/statistics.hpp"

namespace cpgmatch::analysis {

namespace fs = std::filesystem;

namespace {

struct Term {
  const char* name;
  std::function<double(const Trial&)> value;
  const char* paper_sim;  // Supplementary Table 3 of the paper, as printed
  const char* paper_hw;
};

const std::vector<Term>& terms() {
  static const std::vector<Term> t = {
      {"J_feedback", [](const Trial& r) { return r.terms.feedback; }, "0.13", "0.43 ± 0.06"},
      {"J_distance", [](const Trial& r) { return r.terms.distance; }, "1.67", "2.13 ± 0.36"},
      {"J_pitch", [](const Trial& r) { return r.terms.pitch; }, "0.80", "0.85 ± 0.22"},
      {"J_contact", [](const Trial& r) { return r.terms.contact; }, "", ""},
      {"J_periodicity", [](const Trial& r) { return r.terms.periodicity; }, "", ""},
      {"total", [](const Trial& r) { return r.cost; }, "2.59", "4.41 - 5.65"},
  };
  return t;
}

std::string num(double v) { return std::isfinite(v) ? fmt::format("{:.3f}", v) : "-"; }
std::string dat(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : "NaN"; }
nlohmann::json jnum(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace

StudyTrials exploration_trials(const StudyTrials& s) {
  // Synthetic rollouts measured no gait: never drawn or summarised, only counted.
  StudyTrials out = s;
  out.synthetic_left_out += static_cast<int>(std::erase_if(out.trials, [](const Trial& r) { return r.synthetic; }));
  bool any_sim = false;
  for (const auto& r : out.trials) any_sim |= !r.hardware;
  if (!any_sim) return out;
  std::erase_if(out.trials, [](const Trial& r) { return r.hardware; });
  return out;
}

Sim2RealTable sim2real_table(const StudyTrials& s) {
  Sim2RealTable t;
  t.study_name = s.name;
  t.study_id = s.study_id;
  std::vector<const Trial*> sim, hw;
  const Trial* best = nullptr;
  for (const auto& r : s.trials) {
    if (!r.ok || r.synthetic) continue;  // no cost terms: it did not run, or ran no gait
    (r.hardware ? hw : sim).push_back(&r);
    if (!r.hardware && std::isfinite(r.cost) && (best == nullptr || r.cost < best->cost)) best = &r;
  }
  t.sim_rollouts = static_cast<int>(sim.size());
  t.hw_rollouts = static_cast<int>(hw.size());
  t.sim_best_trial = best ? best->trial_id : -1;
  for (const auto& term : terms()) {
    std::vector<double> a, b;
    for (const Trial* r : sim) a.push_back(term.value(*r));
    for (const Trial* r : hw) b.push_back(term.value(*r));
    t.rows.push_back({term.name, mean(a), sample_sd(a), best ? term.value(*best) : std::nan(""), mean(b),
                      sample_sd(b), term.paper_sim, term.paper_hw});
  }
  return t;
}

nlohmann::json sim2real_json(const Sim2RealTable& t) {
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& r : t.rows) {
    rows.push_back({{"term", r.term},
                    {"simulation", {{"mean", jnum(r.sim_mean)}, {"sd", jnum(r.sim_sd)}, {"best", jnum(r.sim_best)}}},
                    {"hardware", {{"mean", jnum(r.hw_mean)}, {"sd", jnum(r.hw_sd)}}},
                    {"paper", {{"simulation", r.paper_sim}, {"hardware", r.paper_hw}}}});
  }
  return {{"study", t.study_name},
          {"study_id", t.study_id},
          {"simulation_rollouts", t.sim_rollouts},
          {"hardware_rollouts", t.hw_rollouts},
          {"simulation_best_trial", t.sim_best_trial},
          {"terms", rows}};
}

std::string sim2real_text(const Sim2RealTable& t) {
  std::string out = fmt::format(
      "Simulation vs hardware (Supplementary Table 3), study {} '{}': {} simulation, {} hardware rollouts\n",
      t.study_id, t.study_name, t.sim_rollouts, t.hw_rollouts);
  out += fmt::format("{:<14} {:>17} {:>9} {:>17}   {:>8} {:>13}\n", "term", "simulation", "sim best", "hardware",
                     "paper sim", "paper hw");
  for (const auto& r : t.rows) {
    out += fmt::format("{:<14} {:>8} ± {:<6} {:>9} {:>8} ± {:<6}   {:>8} {:>13}\n", r.term, num(r.sim_mean),
                       num(r.sim_sd), num(r.sim_best), num(r.hw_mean), num(r.hw_sd),
                       r.paper_sim.empty() ? "-" : r.paper_sim, r.paper_hw.empty() ? "-" : r.paper_hw);
  }
  if (t.hw_rollouts == 0) out += "(no hardware rollout in this study: nothing to compare yet)\n";
  return out;
}

std::vector<fs::path> plot_sim2real(const StudyTrials& s, const fs::path& out_dir) {
  const fs::path dir = fs::absolute(out_dir);
  fs::create_directories(dir);
  const fs::path data = dir / "sim2real.dat";
  {
    // One row per rollout; the term columns of the other kind are NaN, so each kind draws its own series.
    std::ofstream out(data);
    out << "# rollout hardware feedback distance pitch contact periodicity total\n";
    for (const auto& r : s.trials) {
      if (!r.ok) continue;
      out << r.trial_id + 1 << ' ' << int(r.hardware);
      for (const auto& term : terms()) out << ' ' << dat(term.value(r));
      out << '\n';
    }
  }
  static const char* colours[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#000000"};
  std::string plot = "plot ";
  for (std::size_t i = 0; i < terms().size(); ++i) {
    const int col = static_cast<int>(i) + 3;
    plot += fmt::format("{}{} u 1:($2==0?${}:1/0) w lp pt 7 ps 0.4 lc rgb '{}' t '{} (simulation)', "
                        "'' u 1:($2==1?${}:1/0) w p pt 7 ps 1.4 lc rgb '{}' t '{} (hardware)'",
                        i == 0 ? "" : ", ", i == 0 ? gnuplot_quote(data) : "''", col, colours[i], terms()[i].name,
                        col, colours[i], terms()[i].name);
  }
  const std::string body = fmt::format(
      "set datafile missing 'NaN'\nset grid\nset key outside right\n"
      "set title 'Cost terms per rollout: simulation (lines) and hardware (dots), study {}'\n"
      "set xlabel 'rollout'\nset ylabel 'cost term'\n{}",
      s.study_id, plot);
  return render_figure(dir, "sim2real", body, 1100, 600);
}

}  // namespace cpgmatch::analysis
