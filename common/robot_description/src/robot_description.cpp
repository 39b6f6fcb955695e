#include "cpgmatch/robot_description.hpp"

#include <algorithm>
#include <stdexcept>

namespace cpgmatch {

const LinkDescription* RobotDescription::find_link(const std::string& n) const {
  for (const auto& l : links) {
    if (l.name == n) return &l;
  }
  return nullptr;
}

const JointDescription* RobotDescription::find_joint(const std::string& n) const {
  for (const auto& j : joints) {
    if (j.name == n) return &j;
  }
  return nullptr;
}

const GaitPreset* RobotDescription::find_gait(const std::string& n) const {
  for (const auto& g : gaits) {
    if (g.name == n) return &g;
  }
  return nullptr;
}

const LinkDescription& RobotDescription::link(const std::string& n) const {
  if (const auto* l = find_link(n)) return *l;
  throw std::out_of_range("robot " + name + " has no link '" + n + "'");
}

const JointDescription& RobotDescription::joint(const std::string& n) const {
  if (const auto* j = find_joint(n)) return *j;
  throw std::out_of_range("robot " + name + " has no joint '" + n + "'");
}

double RobotDescription::total_mass_kg() const {
  double m = 0.0;
  for (const auto& l : links) m += l.mass_kg;
  return m;
}

const char* to_string(DriveDescription::Kind kind) {
  switch (kind) {
    case DriveDescription::Kind::kPositionPd: return "position_pd";
    case DriveDescription::Kind::kSeriesElastic: return "series_elastic";
    case DriveDescription::Kind::kPassive: return "passive";
  }
  return "passive";
}

}  // namespace cpgmatch

#include "cpgmatch/robot_description_loader.hpp"

namespace cpgmatch {

void apply_robot_legs(ControllerConfig& config, const RobotDescription& robot) {
  LegLayout layout;
  layout.group_names = robot.groups;
  for (const LegDescription& leg : robot.legs) {
    layout.names.push_back(leg.name);
    const auto group = std::find(robot.groups.begin(), robot.groups.end(), leg.group) - robot.groups.begin();
    layout.group_of.push_back(static_cast<int>(group));
  }
  config.legs = layout;
  config.gaits.clear();
  for (const GaitPreset& g : robot.gaits) {
    Gait gait{g.name, PerLeg<double>(g.phase_offsets.size())};
    for (std::size_t i = 0; i < g.phase_offsets.size(); ++i) gait.phase_offsets[i] = g.phase_offsets[i];
    config.gaits.push_back(gait);
  }
  if (robot.find_gait(config.gait) == nullptr) config.gait = robot.gaits.front().name;
}

}  // namespace cpgmatch
