#include "cpgmatch/calibration/measured_trace.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <optional>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/split.hpp"

namespace cpgmatch::calibration {
namespace {

std::vector<std::string_view> split_cells(std::string_view line) { return split_on(line, ','); }

// Column positions of the header, by the names make_csv_trace writes.
class Columns {
 public:
  Columns(const std::string& path, std::string_view header) : path_(path), names_(split_cells(header)) {
    for (auto& name : names_) {
      if (!name.empty() && name.back() == '\r') name.remove_suffix(1);
    }
  }
  std::size_t find(const std::string& name) const {
    for (std::size_t i = 0; i < names_.size(); ++i) {
      if (names_[i] == name) return i;
    }
    throw InputError(fmt::format("{}:1: no column '{}' (not a `cpgmatch rollout --trace` file?)", path_, name));
  }
  // The legs, in column order: every NAME with a NAME_hip_target_rad column (make_csv_trace names them so).
  std::vector<std::string> leg_names() const {
    static constexpr std::string_view kSuffix = "_hip_target_rad";
    std::vector<std::string> legs;
    for (const auto name : names_) {
      if (name.size() > kSuffix.size() && name.substr(name.size() - kSuffix.size()) == kSuffix) {
        legs.emplace_back(name.substr(0, name.size() - kSuffix.size()));
      }
    }
    return legs;
  }

 private:
  std::string path_;
  std::vector<std::string_view> names_;
};

struct LegColumns {
  std::size_t hip_target, hip, knee_target, knee, contact, foot_force;
};

double number(const std::string& path, long line_no, const std::vector<std::string_view>& cells, std::size_t column,
              const char* name_for_message, const std::string& leg = "") {
  const std::string name = leg.empty() ? name_for_message : fmt::format("{}_{}", leg, name_for_message);
  if (column >= cells.size()) throw InputError(fmt::format("{}:{}: column '{}' is missing on this row", path, line_no, name));
  double value = 0.0;
  std::string_view cell = cells[column];
  if (!cell.empty() && cell.back() == '\r') cell.remove_suffix(1);
  const auto [end, ec] = std::from_chars(cell.data(), cell.data() + cell.size(), value);
  if (ec != std::errc() || end != cell.data() + cell.size() || !std::isfinite(value)) {
    throw InputError(fmt::format("{}:{}: column '{}': '{}' is not a finite number", path, line_no, name, cell));
  }
  return value;
}

}  // namespace

MeasuredTrace read_trace_csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("{}: cannot open the trace", path));
  std::string header;
  if (!std::getline(in, header)) throw InputError(fmt::format("{}:1: empty trace (no header)", path));
  const Columns columns(path, header);
  const std::size_t time_col = columns.find("time_s"), pitch_col = columns.find("pitch_rad"),
                    vx_col = columns.find("vx_mps");
  const std::vector<std::string> leg_names = columns.leg_names();
  if (leg_names.empty() || leg_names.size() > kMaxLegs) {
    throw InputError(fmt::format("{}:1: {} legs (columns LEG_hip_target_rad); a trace has 1 to {}", path, leg_names.size(), kMaxLegs));
  }
  PerLeg<LegColumns> leg_cols(leg_names.size());
  for (std::size_t leg = 0; leg < leg_names.size(); ++leg) {
    const std::string& l = leg_names[leg];
    leg_cols[leg] = {columns.find(l + "_hip_target_rad"), columns.find(l + "_hip_rad"),
                     columns.find(l + "_knee_target_rad"), columns.find(l + "_knee_rad"), columns.find(l + "_contact"),
                     columns.find(l + "_foot_force_n")};
  }
  MeasuredTrace trace;
  trace.source = path;
  std::string line;
  long line_no = 1;
  std::optional<double> period;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line == "\r") continue;
    const auto cells = split_cells(line);
    MeasuredTick tick;
    tick.time_s = number(path, line_no, cells, time_col, "time_s");
    tick.pitch_rad = number(path, line_no, cells, pitch_col, "pitch_rad");
    tick.vx_mps = number(path, line_no, cells, vx_col, "vx_mps");
    tick.legs = PerLeg<MeasuredLeg>(leg_names.size());
    for (std::size_t leg = 0; leg < leg_names.size(); ++leg) {
      const std::string& l = leg_names[leg];
      const LegColumns& c = leg_cols[leg];
      MeasuredLeg& m = tick.legs[leg];
      m.hip_target_rad = number(path, line_no, cells, c.hip_target, "hip_target_rad", l);
      m.hip_rad = number(path, line_no, cells, c.hip, "hip_rad", l);
      m.knee_target_rad = number(path, line_no, cells, c.knee_target, "knee_target_rad", l);
      m.knee_rad = number(path, line_no, cells, c.knee, "knee_rad", l);
      const double contact = number(path, line_no, cells, c.contact, "contact", l);
      if (contact != 0.0 && contact != 1.0) {
        throw InputError(fmt::format("{}:{}: column '{}_contact': {} is not 0 or 1", path, line_no, l, contact));
      }
      m.contact = contact == 1.0;
      m.foot_force_n = number(path, line_no, cells, c.foot_force, "foot_force_n", l);
    }
    // The replay re-runs the rollout from its start at the control rate: the ticks must be that grid.
    const std::size_t index = trace.ticks.size();
    if (index == 0 && std::abs(tick.time_s) > 1e-6) {
      throw InputError(fmt::format("{}:{}: time_s {} : a trace must start at the rollout's start (t = 0)", path,
                                   line_no, tick.time_s));
    }
    if (index == 1) period = tick.time_s;
    // The CSV keeps 4 decimals of time: allow that rounding.
    if (index >= 1 && (!(*period > 0.0) || std::abs(tick.time_s - index * *period) > 2e-4)) {
      throw InputError(fmt::format("{}:{}: time_s {}: ticks must be evenly spaced from t = 0 (period {} s)", path,
                                   line_no, tick.time_s, *period));
    }
    trace.ticks.push_back(tick);
  }
  if (trace.ticks.size() < 2) throw InputError(fmt::format("{}: the trace has fewer than two ticks", path));
  return trace;
}

}  // namespace cpgmatch::calibration
