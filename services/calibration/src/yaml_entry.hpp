// A robot.yaml entry by its path (robot_values.hpp's RobotValueSite::yaml_path). Private to
// services/calibration.
#pragma once

#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace cpgmatch::calibration {

// The node at `path`, undefined when robot.yaml leaves it out. reset() rebinds the handle; yaml-cpp's
// operator= would overwrite the node it refers to.
inline YAML::Node yaml_entry(const YAML::Node& root, const std::vector<std::string>& path) {
  YAML::Node node;
  node.reset(root);
  for (const std::string& key : path) {
    YAML::Node next;
    if (node.IsSequence() && std::stoul(key) < node.size()) {
      next.reset(node[std::stoul(key)]);
    } else if (node.IsMap() && node[key]) {
      next.reset(node[key]);
    } else {
      return YAML::Node(YAML::NodeType::Undefined);
    }
    node.reset(next);
  }
  return node;
}

}  // namespace cpgmatch::calibration
