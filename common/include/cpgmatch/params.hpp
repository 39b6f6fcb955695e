// The CPG parameters the paper optimises, with their names, units and valid ranges.
//
// Parameter names are part of the public contract: the same strings are used in YAML files, `--set`
// flags, JSON output and DDS samples. Angles are radians, frequency is hertz, the rest are fractions.
#pragma once

#include <array>
#include <map>
#include <string>
#include <string_view>

namespace cpgmatch {

struct CpgParameters {
  double hip_offset = 0.0;          // rad, mean hip angle; positive moves the foot forward
  double hip_amplitude = 0.25;      // rad, half the hip excursion from touchdown to toe-off
  double knee_amplitude = 0.5236;   // rad, extra knee flexion at mid-swing (paper: fixed 30 degrees)
  double frequency = 1.0;           // Hz, step frequency (paper: fixed 1 Hz)
  double duty_factor_front = 0.5;   // fraction of the cycle in stance, front legs
  double duty_factor_hind = 0.5;    // fraction of the cycle in stance, hind legs
  double knee_phase_shift = 0.1;    // fraction of stance by which knee flexion leads hip protraction
  double overswing = 0.1;           // fraction of swing spent retracting the leg before touchdown
};

// Describes one parameter: where it lives in CpgParameters, its unit and its valid closed range.
struct ParameterInfo {
  std::string_view name;
  double CpgParameters::*member;
  double low;
  double high;
  std::string_view unit;
  std::string_view description;
};

// Every parameter in a fixed order (the order used in tables and vectors).
const std::array<ParameterInfo, 8>& parameter_table();

// Looks up a parameter by name; throws InputError listing the valid names when unknown.
const ParameterInfo& parameter_info(std::string_view name);

// Sets one parameter after checking that it is finite and inside its range.
// `origin` (e.g. "params.yaml:4" or "--set") is put in front of any error message.
void set_parameter(CpgParameters& params, std::string_view name, double value,
                   std::string_view origin = "");

double get_parameter(const CpgParameters& params, std::string_view name);

// Checks every field; throws InputError naming the first bad one.
void validate(const CpgParameters& params);

// name -> value, in table order.
std::map<std::string, double> to_map(const CpgParameters& params);

// Parses "name=value" as given to `--set`.
void apply_assignment(CpgParameters& params, std::string_view assignment);

}  // namespace cpgmatch
