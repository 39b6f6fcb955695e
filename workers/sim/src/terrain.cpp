#include "cpgmatch/sim/terrain.hpp"

#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch::sim {
namespace {

double parse_metres(const std::string& text, const std::string& whole, const char* what) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v)) {
    throw InputError(fmt::format("--terrain '{}': {} '{}' is not a number of metres", whole, what, text));
  }
  return v;
}

}  // namespace

const char* TerrainSpec::syntax() {
  return "flat | step:HEIGHT@DISTANCE (a step up or down of HEIGHT m, within +-0.15, at DISTANCE m >= 0.35 ahead) | "
         "rough:AMPLITUDE (random tiles of up to AMPLITUDE m, within [0, 0.1]) | shift:HEIGHT@TIME (the ground moves "
         "HEIGHT m, within +-0.1, at TIME s)";
}

TerrainSpec TerrainSpec::parse(const std::string& text) {
  TerrainSpec t;
  if (text == "flat") return t;
  if (text.rfind("step:", 0) == 0) {
    const std::string rest = text.substr(5);
    const auto at = rest.find('@');
    if (at == std::string::npos) {
      throw InputError(fmt::format("--terrain '{}': expected step:HEIGHT@DISTANCE, e.g. step:-0.02@1.0", text));
    }
    t.kind = Kind::kStep;
    t.step_height_m = parse_metres(rest.substr(0, at), text, "height");
    t.step_distance_m = parse_metres(rest.substr(at + 1), text, "distance");
    if (std::abs(t.step_height_m) > 0.15) {
      throw InputError(fmt::format("--terrain '{}': step height must be within +-0.15 m", text));
    }
    if (t.step_distance_m < 0.35) {
      throw InputError(fmt::format("--terrain '{}': step distance must be >= 0.35 m (ahead of the front feet)", text));
    }
    return t;
  }
  if (text.rfind("rough:", 0) == 0) {
    t.kind = Kind::kRough;
    t.rough_amplitude_m = parse_metres(text.substr(6), text, "amplitude");
    if (t.rough_amplitude_m < 0.0 || t.rough_amplitude_m > 0.1) {
      throw InputError(fmt::format("--terrain '{}': roughness amplitude must be in [0, 0.1] m", text));
    }
    return t;
  }
  if (text.rfind("shift:", 0) == 0) {
    const std::string rest = text.substr(6);
    const auto at = rest.find('@');
    if (at == std::string::npos) throw InputError(fmt::format("--terrain '{}': expected shift:HEIGHT@TIME", text));
    t.kind = Kind::kShift;
    t.shift_height_m = parse_metres(rest.substr(0, at), text, "height");
    t.shift_time_s = parse_metres(rest.substr(at + 1), text, "time");
    if (std::abs(t.shift_height_m) > 0.1) throw InputError(fmt::format("--terrain '{}': shift must be within +-0.1 m", text));
    if (t.shift_time_s < 0.0) throw InputError(fmt::format("--terrain '{}': shift time must be >= 0 s", text));
    return t;
  }
  throw InputError(fmt::format("--terrain '{}': expected {}", text, syntax()));
}

std::string TerrainSpec::describe() const {
  switch (kind) {
    case Kind::kFlat: return "flat";
    case Kind::kStep: return fmt::format("step:{}@{}", step_height_m, step_distance_m);
    case Kind::kRough: return fmt::format("rough:{}", rough_amplitude_m);
    case Kind::kShift: return fmt::format("shift:{}@{}", shift_height_m, shift_time_s);
  }
  return "?";
}

}  // namespace cpgmatch::sim
