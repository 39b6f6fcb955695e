// Fig. 4 of the paper from a rollout trace (the CSV `cpgmatch rollout --trace` writes; its columns are
// made in common/src/rollout.cpp, make_csv_trace).
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include <fmt/format.h>

#include "cpgmatch/analysis/gnuplot.hpp"
#include "cpgmatch/analysis/plots.hpp"

namespace cpgmatch::analysis {

namespace fs = std::filesystem;

namespace {

const std::vector<std::string> kMechanisms = {"ltd", "etd", "eto", "lto"};
const std::vector<std::string> kMechanismNames = {"late touchdown", "early touchdown", "early toe-off", "late toe-off"};
// The paper's colour code (Fig. 4, Supplementary Fig. 2): LTD red, ETD purple, ETO green, LTO yellow.
const std::vector<std::string> kMechanismColours = {"#d62728", "#9467bd", "#2ca02c", "#e6b800"};
constexpr std::size_t kMaxRows = 4000;  // plenty for a few seconds of gait; keeps the SVG small

struct Trace {
  // The robot's legs, in the trace's column order: every NAME with a NAME_phase column (make_csv_trace names
  // them so), 1 to 8 of them (Morti FL FR HL HR, a hexapod L1 R1 ...). The joint panels show the first leg;
  // the feedback bands the first two.
  std::vector<std::string> legs;
  std::vector<std::string> columns;  // the ones Fig. 4 needs, in this order
  std::vector<std::vector<double>> rows;
};

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  for (std::string cell; std::getline(ss, cell, ',');) out.push_back(cell);
  return out;
}

std::vector<std::string> legs_of(const std::vector<std::string>& header) {
  static constexpr std::string_view kPhase = "_phase";
  std::vector<std::string> legs;
  for (const auto& name : header) {
    if (name.size() > kPhase.size() && name.compare(name.size() - kPhase.size(), kPhase.size(), kPhase) == 0) {
      legs.push_back(name.substr(0, name.size() - kPhase.size()));
    }
  }
  return legs;
}

// The legs whose feedback mechanisms get bands: the first two (Morti's front pair), or the only one.
std::vector<std::string> banded_legs(const std::vector<std::string>& legs) {
  return {legs.begin(), legs.begin() + static_cast<std::ptrdiff_t>(std::min<std::size_t>(2, legs.size()))};
}

std::vector<std::string> needed_columns(const std::vector<std::string>& legs) {
  std::vector<std::string> c = {"time_s"};
  for (const auto& leg : legs) c.push_back(leg + "_phase");
  for (const char* q : {"_hip_target_rad", "_hip_rad", "_knee_target_rad", "_knee_rad", "_contact"}) c.push_back(legs.front() + q);
  for (const auto& leg : banded_legs(legs)) {
    for (const auto& m : kMechanisms) c.push_back(fmt::format("{}_{}", leg, m));
  }
  return c;
}

Trace read_trace(const fs::path& csv, double window_s) {
  std::ifstream in(csv);
  if (!in) throw std::runtime_error(fmt::format("{}: cannot open the trace", csv.string()));
  std::string line;
  if (!std::getline(in, line)) throw std::runtime_error(fmt::format("{}: empty trace", csv.string()));
  const auto header = split(line);
  Trace t;
  t.legs = legs_of(header);
  if (t.legs.empty() || t.legs.size() > 8) {
    throw std::runtime_error(fmt::format("{}: {} legs (columns LEG_phase); Fig. 4 draws 1 to 8 (not a `cpgmatch rollout "
                                         "--trace` file?)", csv.string(), t.legs.size()));
  }
  t.columns = needed_columns(t.legs);
  std::vector<std::size_t> index;
  for (const auto& name : t.columns) {
    const auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end()) {
      throw std::runtime_error(fmt::format("{}: no column '{}' (not a `cpgmatch rollout --trace` file?)", csv.string(), name));
    }
    index.push_back(static_cast<std::size_t>(it - header.begin()));
  }
  std::vector<std::vector<double>> all;
  while (std::getline(in, line)) {
    const auto cells = split(line);
    std::vector<double> row;
    for (std::size_t i : index) row.push_back(i < cells.size() ? std::strtod(cells[i].c_str(), nullptr) : std::nan(""));
    all.push_back(std::move(row));
  }
  if (all.empty()) throw std::runtime_error(fmt::format("{}: the trace has no samples", csv.string()));
  const double start = all.back()[0] - window_s;
  std::vector<std::vector<double>> window;
  for (auto& r : all) {
    if (r[0] >= start) window.push_back(std::move(r));
  }
  const std::size_t stride = std::max<std::size_t>(1, window.size() / kMaxRows);
  for (std::size_t i = 0; i < window.size(); i += stride) t.rows.push_back(window[i]);
  return t;
}

// Shaded rectangles over every interval in which column `col` is 1 (stance: foot in contact).
std::string stance_objects(const Trace& t, std::size_t col) {
  std::string out;
  double begin = std::nan("");
  for (std::size_t i = 0; i < t.rows.size(); ++i) {
    const bool on = t.rows[i][col] > 0.5;
    if (on && std::isnan(begin)) begin = t.rows[i][0];
    if ((!on || i + 1 == t.rows.size()) && !std::isnan(begin)) {
      out += fmt::format("set object rect from {:.4f},graph 0 to {:.4f},graph 1 fc rgb '#e8e8e8' fs solid 1.0 noborder behind\n",
                         begin, t.rows[i][0]);
      begin = std::nan("");
    }
  }
  return out;
}

// In words, which legs move together (phases equal within 2% of a cycle in every sample shown): what the
// phase rows show side by side.
template <typename Column>
std::string phase_pairs(const Trace& t, Column col) {
  std::vector<std::string> pairs;
  const std::vector<std::string>& legs = t.legs;
  for (std::size_t a = 0; a < legs.size(); ++a) {
    for (std::size_t b = a + 1; b < legs.size(); ++b) {
      const int ca = col(legs[a] + "_phase") - 1, cb = col(legs[b] + "_phase") - 1;
      bool together = true;
      for (const auto& r : t.rows) {
        const double diff = std::abs(std::remainder(r[static_cast<std::size_t>(ca)] - r[static_cast<std::size_t>(cb)], 1.0));
        together &= diff < 0.02;
      }
      if (together) pairs.push_back(legs[a] + " = " + legs[b]);
    }
  }
  if (pairs.empty()) return "no two legs in phase";
  std::string out = "in phase: ";
  for (std::size_t i = 0; i < pairs.size(); ++i) out += (i ? ", " : "") + pairs[i];
  return out;
}

}  // namespace

FigureFiles plot_trace(const fs::path& trace_csv, const fs::path& out_dir, double window_s) {
  const Trace t = read_trace(trace_csv, window_s);
  const fs::path dir = fs::absolute(out_dir);
  fs::create_directories(dir);
  const fs::path data = dir / "fig4.dat";
  {
    std::ofstream out(data);
    out << "#";
    for (const auto& c : t.columns) out << ' ' << c;
    out << '\n';
    for (const auto& r : t.rows) {
      for (std::size_t i = 0; i < r.size(); ++i) out << (i ? " " : "") << fmt::format("{:.5g}", r[i]);
      out << '\n';
    }
  }
  auto col = [&](const std::string& name) {
    return static_cast<int>(std::find(t.columns.begin(), t.columns.end(), name) - t.columns.begin()) + 1;
  };
  const std::string d = gnuplot_quote(data);
  const std::vector<std::string>& legs = t.legs;
  const std::string& first_leg = legs.front();
  const std::string stance = stance_objects(t, static_cast<std::size_t>(col(first_leg + "_contact") - 1));
  const double shown_s = t.rows.back()[0] - t.rows.front()[0];  // the trace may be shorter than the window
  std::string body = fmt::format(
      "set multiplot layout 4,1 title \"Fig. 4: CPG output and elastic feedback (last {:.1f} s of the rollout; grey: {} "
      "stance)\\nphases: one row per leg ({})\"\n"
      "set grid\nset key outside right\nset lmargin 10\nset rmargin 24\n",
      shown_s, first_leg, phase_pairs(t, col));
  // Each leg's phase (0..1 per cycle) in a row of its own: in a trot FL moves with HR and FR with HL, and
  // one shared axis drew each pair as a single line (the second hid the first in every sample).
  body += fmt::format("set ylabel 'phase (0-1 per cycle)'\nset yrange [-0.15:{:.2f}]\nset ytics (", legs.size() - 0.05);
  for (std::size_t i = 0; i < legs.size(); ++i) {
    body += fmt::format("{}'{}' {}", i ? ", " : "", legs[i], legs.size() - 1 - i + 0.4);
  }
  body += ")\nset key off\nset grid xtics\n";
  body += "plot ";
  for (std::size_t i = 0; i < legs.size(); ++i) {
    const std::size_t row = legs.size() - 1 - i;
    body += fmt::format("{}{} u 1:({}+0.8*${}) w l lw 1.5 lc {}", i ? ", " : "", i ? "''" : d, row, col(legs[i] + "_phase"),
                        i + 1);
  }
  body += "\nset yrange [*:*]\nset ytics autofreq\nset grid xtics ytics\nset key outside right\n";
  body += "\n" + stance;
  body += fmt::format("set ylabel '{} hip, rad'\nplot {} u 1:{} w l lw 1.5 dt 2 t 'target', '' u 1:{} w l lw 1.5 t 'measured'\n",
                      first_leg, d, col(first_leg + "_hip_target_rad"), col(first_leg + "_hip_rad"));
  body += fmt::format("set ylabel '{} knee, rad'\nplot {} u 1:{} w l lw 1.5 dt 2 t 'target', '' u 1:{} w l lw 1.5 t 'measured'\n",
                      first_leg, d, col(first_leg + "_knee_target_rad"), col(first_leg + "_knee_rad"));
  // Four bands per banded leg, the first leg's on top; labels as "FL LTD".
  static const std::vector<std::string> kShort = {"LTD", "ETD", "ETO", "LTO"};
  const std::vector<std::string> banded = banded_legs(legs);
  int band = static_cast<int>(banded.size() * kMechanisms.size());
  body += fmt::format("unset object\nset ylabel 'feedback'\nset xlabel 'time, s'\nset yrange [0.3:{}.7]\nset ytics (", band);
  for (std::size_t l = 0, b = static_cast<std::size_t>(band); l < banded.size(); ++l) {
    for (std::size_t m = 0; m < kMechanisms.size(); ++m, --b) body += fmt::format("{}'{} {}' {}", l + m ? ", " : "", banded[l], kShort[m], b);
  }
  body += ")\nplot ";
  bool first = true;
  for (const std::string& leg : banded) {
    for (std::size_t m = 0; m < kMechanisms.size(); ++m, --band) {
      // A line through the samples where the mechanism is active, broken (1/0) where it is not: a band.
      body += fmt::format("{}{} u 1:(${}>0.5?{}:1/0) w l lw 10 lc rgb '{}' t '{}'", first ? "" : ", ", first ? d : "''",
                          col(fmt::format("{}_{}", leg, kMechanisms[m])), band, kMechanismColours[m],
                          leg == first_leg ? kMechanismNames[m] : "");
      first = false;
    }
  }
  body += "\n";
  return render_figure(dir, "fig4", body, 1000, 1000);
}

}  // namespace cpgmatch::analysis
