#include "cpgmatch/params.hpp"

#include <cmath>
#include <cstdlib>
#include <string>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch {

const std::array<ParameterInfo, 8>& parameter_table() {
  // Ranges: wide enough for every gait the model can physically produce, narrow enough that the CPG
  // stays well defined (duty factors away from 0 and 1, overswing and knee shift below half a phase).
  static const std::array<ParameterInfo, 8> table{{
      {"hip_offset", &CpgParameters::hip_offset, -0.6, 0.6, "rad",
       "mean hip angle, positive moves the foot forward"},
      {"hip_amplitude", &CpgParameters::hip_amplitude, 0.0, 0.7, "rad",
       "half the hip excursion between touchdown and toe-off"},
      {"knee_amplitude", &CpgParameters::knee_amplitude, 0.0, 1.2, "rad",
       "extra knee flexion at mid-swing"},
      {"frequency", &CpgParameters::frequency, 0.2, 3.0, "Hz", "step frequency"},
      {"duty_factor_front", &CpgParameters::duty_factor_front, 0.2, 0.8, "1",
       "stance fraction of the front legs"},
      {"duty_factor_hind", &CpgParameters::duty_factor_hind, 0.2, 0.8, "1",
       "stance fraction of the hind legs"},
      {"knee_phase_shift", &CpgParameters::knee_phase_shift, 0.0, 0.5, "1",
       "fraction of stance by which knee flexion leads hip protraction"},
      {"overswing", &CpgParameters::overswing, 0.0, 0.5, "1",
       "fraction of swing spent retracting the leg before touchdown"},
  }};
  return table;
}

const ParameterInfo& parameter_info(std::string_view name) {
  for (const auto& info : parameter_table()) {
    if (info.name == name) return info;
  }
  std::string names;
  for (const auto& info : parameter_table()) {
    names += names.empty() ? "" : ", ";
    names += info.name;
  }
  throw InputError(fmt::format("unknown parameter '{}' (known: {})", name, names));
}

void set_parameter(CpgParameters& params, std::string_view name, double value,
                   std::string_view origin) {
  const std::string prefix = origin.empty() ? "" : std::string(origin) + ": ";
  const ParameterInfo* info = nullptr;
  try {
    info = &parameter_info(name);
  } catch (const InputError& e) {
    throw InputError(prefix + e.what());
  }
  if (!std::isfinite(value)) {
    throw InputError(fmt::format("{}parameter '{}' must be a finite number, got {}", prefix, name, value));
  }
  if (value < info->low || value > info->high) {
    throw InputError(fmt::format("{}parameter '{}' = {} is outside its range [{}, {}] {}", prefix, name,
                                 value, info->low, info->high, info->unit));
  }
  params.*(info->member) = value;
}

double get_parameter(const CpgParameters& params, std::string_view name) {
  return params.*(parameter_info(name).member);
}

void validate(const CpgParameters& params) {
  for (const auto& info : parameter_table()) {
    CpgParameters copy = params;
    set_parameter(copy, info.name, params.*(info.member));
  }
}

std::map<std::string, double> to_map(const CpgParameters& params) {
  std::map<std::string, double> out;
  for (const auto& info : parameter_table()) out[std::string(info.name)] = params.*(info.member);
  return out;
}

void apply_assignment(CpgParameters& params, std::string_view assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string_view::npos || eq == 0) {
    throw InputError(fmt::format("--set '{}': expected name=value", assignment));
  }
  const std::string name(assignment.substr(0, eq));
  const std::string text(assignment.substr(eq + 1));
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size()) {
    throw InputError(fmt::format("--set {}: '{}' is not a number", name, text));
  }
  set_parameter(params, name, value, "--set");
}

}  // namespace cpgmatch
