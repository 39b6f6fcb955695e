// The model values calibration may fit, by their name in the model YAML (section.key), each with the
// range physics allows it: the bounds keep the solver among robots that could exist, not among numbers
// that merely fit.
#pragma once

#include <string>
#include <vector>

#include "cpgmatch/sim/morti_model.hpp"

namespace cpgmatch::calibration {

struct ModelValue {
  std::string name;  // "knee_spring.stiffness_nm_per_rad": the YAML section and key
  std::string unit;
  double lower = 0.0;  // physical bounds, in the value's unit
  double upper = 0.0;
  std::string bounds_reason;
  double& (*ref)(sim::PlanarLegModel&);  // where the value lives in the model
  // False for a value only a robot's description has (a spring across the knee): Morti's model file has no
  // section for it, so a model-file calibration refuses it (robot_values.hpp says where it lives in a robot).
  bool in_model_files = true;

  double get(sim::PlanarLegModel model) const { return ref(model); }
  void set(sim::PlanarLegModel& model, double value) const { ref(model) = value; }
};

// Every value calibration knows, in a fixed order.
const std::vector<ModelValue>& calibratable_values();
// The value of that name; InputError naming it and listing the known names otherwise.
const ModelValue& find_model_value(const std::string& name);
// Splits "a.b,c.d" into names, each looked up (InputError for an unknown or repeated one).
std::vector<const ModelValue*> parse_model_value_list(const std::string& comma_separated);

}  // namespace cpgmatch::calibration
