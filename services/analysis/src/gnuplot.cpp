#include "cpgmatch/analysis/gnuplot.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

namespace cpgmatch::analysis {

namespace fs = std::filesystem;

bool gnuplot_available() { return std::system("command -v gnuplot >/dev/null 2>&1") == 0; }

std::string gnuplot_number(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : "NaN"; }

std::string gnuplot_quote(const fs::path& p) {
  std::string out = "'";
  for (char c : p.string()) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

std::vector<fs::path> render_figure(const fs::path& dir_in, const std::string& stem, const std::string& body,
                                    int width_px, int height_px) {
  const fs::path dir = fs::absolute(dir_in);
  fs::create_directories(dir);
  const fs::path script = dir / (stem + ".gp"), png = dir / (stem + ".png"), svg = dir / (stem + ".svg");
  const fs::path log = dir / (stem + ".gnuplot.log");
  {
    std::ofstream out(script);
    if (!out) throw PlotError(fmt::format("{}: cannot write the gnuplot script", script.string()));
    out << "# " << stem << ": written by cpgmatch; every path is absolute\n";
    out << fmt::format("set terminal pngcairo size {},{} noenhanced font ',10'\nset output {}\n", width_px, height_px,
                       gnuplot_quote(png));
    out << body << "\nunset multiplot\nset output\nreset\n";
    out << fmt::format("set terminal svg size {},{} noenhanced dynamic\nset output {}\n", width_px, height_px,
                       gnuplot_quote(svg));
    out << body << "\nunset multiplot\nset output\n";
  }
  if (!gnuplot_available()) {
    throw PlotError(fmt::format("gnuplot not found on PATH: {} written, no figures", script.string()));
  }
  const std::string cmd = fmt::format("gnuplot {} >{} 2>&1", gnuplot_quote(script), gnuplot_quote(log));
  if (std::system(cmd.c_str()) != 0) {
    std::ifstream in(log);
    std::stringstream messages;
    messages << in.rdbuf();
    throw PlotError(fmt::format("gnuplot failed on {}: {}", script.string(), messages.str()));
  }
  fs::remove(log);
  return {png, svg};
}

}  // namespace cpgmatch::analysis
