#include "cpgmatch/calibration/calibrated_model.hpp"

#include <algorithm>
#include <sstream>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch::calibration {
namespace {

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::string without_double_quotes(std::string s) {
  std::replace(s.begin(), s.end(), '"', '\'');
  return s;
}

std::string rms_summary(const ChannelRms& r) {
  return fmt::format(
      "knee {:.4f} rad, hip {:.4f} rad, pitch {:.4f} rad, speed {:.3f} m/s, contact mismatch {:.1f}%, foot force {:.2f} N",
      r.knee_rad, r.hip_rad, r.pitch_rad, r.speed_mps, 100.0 * r.contact_mismatch, r.foot_force_n);
}

std::string entry_for(const std::string& key, const FittedValue& v, const CalibrationResult& r,
                      const std::string& previous_source) {
  return fmt::format("{}: {{value: {:.6g}, source: \"{}\"}}", key, v.estimate, calibrated_source(v, r, previous_source));
}

std::string indent_of(const std::string& line) { return line.substr(0, line.find_first_not_of(' ')); }

}  // namespace

std::string calibrated_source(const FittedValue& v, const CalibrationResult& r, const std::string& previous_source) {
  return fmt::format("calibrated: estimate {:.6g} +- {:.3g} (1 sd, {}) {}, from {:.6g}; cost {:.6g} -> {:.6g}{}{}{}",
                     v.estimate, v.standard_deviation, v.sd_from == "windows" ? "the windows' spread" : "covariance",
                     v.unit, v.initial, r.cost_before, r.cost_after, v.at_bound ? "; AT ITS PHYSICAL BOUND" : "",
                     v.identifiable ? "" : "; NOT IDENTIFIABLE: " + without_double_quotes(v.not_identifiable_reason),
                     previous_source.empty() ? "" : "; before: " + without_double_quotes(previous_source));
}

std::string calibration_header(const std::string& model_source, const CalibrationResult& result,
                               const std::vector<std::string>& trace_sources) {
  std::ostringstream out;
  out << "# Calibrated by `cpgmatch calibrate` from " << model_source << " on " << trace_sources.size()
      << " trace(s): " << fmt::format("{}", fmt::join(trace_sources, ", ")) << "\n";
  out << fmt::format("# Fitted {} value(s), {} residuals, {} iterations, {} replays; cost {:.6g} -> {:.6g}.\n",
                     result.values.size(), result.residual_count, result.iterations, result.simulations,
                     result.cost_before, result.cost_after);
  out << "# RMS misfit before: " << rms_summary(result.rms_before) << "\n";
  out << "# RMS misfit after:  " << rms_summary(result.rms_after) << "\n";
  if (result.window_count >= 2) {
    out << fmt::format("# Standard deviations: the larger of Ceres' covariance (scaled by the fit's residual variance) and\n"
                       "# the spread of {} windows fitted alone, each note says which (docs/calibration.md).\n", result.window_count);
  } else {
    out << "# Standard deviations: Ceres covariance scaled by the fit's residual variance, no windows to compare;\n"
           "# consecutive ticks are correlated, so they are lower bounds on the real uncertainty (docs/calibration.md).\n";
  }
  return out.str();
}

std::string calibrated_model_text(const std::string& model_text, const std::string& model_source,
                                  const CalibrationResult& result, const std::vector<std::string>& trace_sources) {
  // Parsed through YamlReader for its checks (size, syntax, one document) and yaml-cpp's line marks.
  const YamlReader reader = YamlReader::from_string(model_text, model_source);
  std::vector<std::string> lines = lines_of(model_text);
  std::vector<std::string> appended;  // sections the start model does not have
  for (const FittedValue& v : result.values) {
    const std::string section = v.name.substr(0, v.name.find('.'));
    const std::string key = v.name.substr(v.name.find('.') + 1);
    const YAML::Node sec = reader.node()[section];
    if (!sec) {
      appended.push_back(fmt::format("{}:\n  {}", section, entry_for(key, v, result, "")));
      continue;
    }
    const YAML::Node entry = sec[key];
    if (!entry) {
      // Insert before the section's first key, with its indentation.
      const auto line = static_cast<std::size_t>(sec.begin()->first.Mark().line);
      lines.insert(lines.begin() + static_cast<long>(line), indent_of(lines[line]) + entry_for(key, v, result, ""));
      continue;
    }
    const auto line = static_cast<std::size_t>(entry.Mark().line);
    const bool one_line = entry.IsScalar() || (entry.IsMap() && entry.Style() == YAML::EmitterStyle::Flow &&
                                               lines[line].find('}') != std::string::npos);
    if (!one_line || lines[line].find(key + ":") == std::string::npos) {
      throw InputError(fmt::format("{}:{}: {}: calibration rewrites only one-line entries ('{}: {{value: ..., source: "
                                   "...}}' or '{}: NUMBER')",
                                   model_source, line + 1, v.name, key, key));
    }
    std::string previous_source;
    if (entry.IsMap() && entry["source"]) previous_source = entry["source"].as<std::string>();
    lines[line] = indent_of(lines[line]) + entry_for(key, v, result, previous_source);
  }
  std::ostringstream out;
  out << calibration_header(model_source, result, trace_sources);
  for (const auto& l : lines) out << l << "\n";
  for (const auto& a : appended) out << a << "\n";
  return out.str();
}

}  // namespace cpgmatch::calibration
