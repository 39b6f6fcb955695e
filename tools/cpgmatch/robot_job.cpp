#include "robot_job.hpp"

#include <algorithm>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/sim/planar_leg_model.hpp"
#include "cpgmatch/study/robot_file.hpp"

namespace cpgmatch::cli {

const std::map<std::string, double>* robot_preset(const RobotDescription& robot, const std::string& name) {
  const auto it = robot.presets.find(name.empty() ? "default" : name);
  if (it != robot.presets.end()) return &it->second;
  if (name.empty()) return nullptr;
  std::vector<std::string> names;
  for (const auto& [n, values] : robot.presets) names.push_back(n);
  throw InputError(fmt::format("--preset '{}': robot '{}' has presets {}", name, robot.name,
                               names.empty() ? std::string("(none)") : fmt::format("{}", fmt::join(names, ", "))));
}

void apply_robot(sim::SimRolloutJob& job, const RobotDescription& robot, const std::string& preset,
                 const std::string& gait) {
  job.model = sim::planar_leg_model(robot);
  if (!gait.empty()) {
    if (robot.find_gait(gait) == nullptr) {
      std::vector<std::string> names;
      for (const GaitPreset& g : robot.gaits) names.push_back(g.name);
      throw InputError(fmt::format("--gait '{}': robot '{}' has gaits {}", gait, robot.name, fmt::join(names, ", ")));
    }
    job.settings.controller.gait = gait;
  }
  apply_robot_legs(job.settings.controller, robot);
  if (const auto* values = robot_preset(robot, preset)) {
    for (const auto& [key, value] : *values) set_parameter(job.params, key, value, fmt::format("preset '{}'", preset));
  }
}

bo::SearchSpace robot_search_space(const RobotDescription& robot, const std::string& preset) {
  return study::robot_search_space(robot, robot_preset(robot, preset));
}

}  // namespace cpgmatch::cli
