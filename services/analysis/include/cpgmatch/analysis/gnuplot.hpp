// Running gnuplot: each figure is one script that draws the same body twice, to a PNG (pngcairo) and
// an SVG. Every path in a script is absolute, so gnuplot's working directory never matters (a relative
// output path under a `cd` was what made `study run` print "gnuplot failed").
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace cpgmatch::analysis {

struct PlotError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

bool gnuplot_available();
// A number for a gnuplot data file or script: 6 significant digits, NaN for a missing value (scripts
// declare `set datafile missing 'NaN'`).
std::string gnuplot_number(double v);
// A gnuplot string literal for the path: single-quoted, with embedded quotes doubled.
std::string gnuplot_quote(const std::filesystem::path& p);
// Writes <dir>/<stem>.gp drawing `body` into <dir>/<stem>.png and <dir>/<stem>.svg and runs gnuplot.
// Throws PlotError naming the script and quoting gnuplot's messages when gnuplot is missing or fails.
std::vector<std::filesystem::path> render_figure(const std::filesystem::path& dir, const std::string& stem,
                                                 const std::string& body, int width_px, int height_px);

}  // namespace cpgmatch::analysis
