#include "cpgmatch/calibration/robot_values.hpp"

#include <algorithm>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "cpgmatch/errors.hpp"
#include "yaml_entry.hpp"

namespace cpgmatch::calibration {
namespace {

using Kind = DriveDescription::Kind;

[[noreturn]] void lacks(const ModelValue& value, const RobotDescription& robot, const std::string& why) {
  throw InputError(fmt::format("{}: robot '{}' ({}) {}", value.name, robot.name, robot.yaml_source, why));
}

std::string key_of(const std::string& name) { return name.substr(name.find('.') + 1); }
std::string section_of(const std::string& name) { return name.substr(0, name.find('.')); }

// The index in robot.yaml's parallel_springs of the spring between the links after joints `a` and `b`
// (either way round); -1 for none.
int parallel_spring_index(const RobotDescription& robot, const std::string& a, const std::string& b) {
  for (std::size_t i = 0; i < robot.parallel_springs.size(); ++i) {
    const ParallelSpringDescription& s = robot.parallel_springs[i];
    if ((s.from_role == a && s.to_role == b) || (s.from_role == b && s.to_role == a)) return static_cast<int>(i);
  }
  return -1;
}

const DriveDescription& drive(const ModelValue& value, const RobotDescription& robot, const std::string& role) {
  const auto it = robot.drives.find(role);
  if (it == robot.drives.end()) lacks(value, robot, fmt::format("has no drives.{}", role));
  return it->second;
}

// The site of a value before checking robot.yaml has the entry.
RobotValueSite site_in_description(const ModelValue& value, const RobotDescription& robot) {
  const std::string section = section_of(value.name), key = key_of(value.name);
  RobotValueSite site;
  if (value.name == "trunk.mass_kg") {
    site.file = RobotValueSite::File::kUrdfTrunkMass;
    site.label = fmt::format("{} link '{}' <inertial><mass>", robot.urdf_source, robot.root_link);
    return site;
  }
  if (section == "knee_spring") {
    const DriveDescription& knee = drive(value, robot, "knee");
    if (knee.kind != Kind::kSeriesElastic) {
      const bool parallel = parallel_spring_index(robot, "hip", "knee") >= 0;
      lacks(value, robot,
            fmt::format("has no series knee spring: drives.knee is {}{}", to_string(knee.kind),
                        parallel ? fmt::format("; its spring across the knee is knee_parallel_spring.{}", key) : ""));
    }
    site.yaml_path = {"drives", "knee", key};
  } else if (section == "knee_parallel_spring" || section == "biarticular_spring") {
    const bool across_knee = section == "knee_parallel_spring";
    const int i = parallel_spring_index(robot, "hip", across_knee ? "knee" : "ankle");
    if (i < 0) {
      lacks(value, robot,
            fmt::format("has no {} (parallel_springs has no spring from: hip to: {})",
                        across_knee ? "spring across the knee" : "biarticular spring", across_knee ? "knee" : "ankle"));
    }
    site.yaml_path = {"parallel_springs", std::to_string(i), key};
  } else if (section == "contact" || section == "foot_sensor") {
    site.yaml_path = {section, key};
  } else if (section == "hip_motor") {
    const DriveDescription& hip = drive(value, robot, "hip");
    const auto knee = robot.drives.find("knee");
    // The knee's model reads its motor's torque-speed line (both drive kinds) and, driven directly, its
    // gearbox too: a value fitted on the hip written into a motor the knee shares would change the knee.
    const bool knee_reads_it = knee != robot.drives.end() && knee->second.kind != Kind::kPassive &&
                               knee->second.motor == hip.motor &&
                               (knee->second.kind == Kind::kPositionPd || key == "no_load_speed_rad_s");
    if (knee_reads_it) {
      lacks(value, robot,
            fmt::format("drives its hip and its knee with one motor entry, motors.{} (drives.hip.motor, drives.knee.motor), "
                        "and the knee's model reads its {} too; a value fitted on the hip alone has no entry of its own "
                        "(give the hip a motor entry of its own to fit it)",
                        hip.motor, key));
    }
    site.yaml_path = {"motors", hip.motor, key};
  } else if (value.name == "leg.knee_joint_friction_nm") {
    drive(value, robot, "knee");
    site.yaml_path = {"drives", "knee", "joint_friction_nm"};
  } else {
    lacks(value, robot, "has no entry for it that this version knows (robot_values.cpp)");
  }
  site.label = fmt::format("{}", fmt::join(site.yaml_path, "."));
  if (site.yaml_path.front() == "parallel_springs") {
    site.label = fmt::format("parallel_springs[{}].{}", site.yaml_path[1], site.yaml_path[2]);
  }
  return site;
}

// Values whose physical range scales with the robot: everything but a friction coefficient and the foot
// sensor's sensitivity and lag (a rubber foot grips alike on a small robot and a big one).
bool scales_with_robot(const ModelValue& value) {
  return value.name != "contact.friction" && section_of(value.name) != "foot_sensor";
}

}  // namespace

RobotValueSite robot_value_site(const ModelValue& value, const RobotDescription& robot) {
  RobotValueSite site = site_in_description(value, robot);
  if (site.file == RobotValueSite::File::kRobotYaml) {
    const YAML::Node entry = yaml_entry(YAML::Load(robot.yaml_text), site.yaml_path);
    if (!entry.IsDefined()) {
      lacks(value, robot,
            fmt::format("has no entry {} in its robot.yaml (the loader's default stands in); write it with its value "
                        "and source, then calibrate it",
                        site.label));
    }
  }
  return site;
}

std::vector<ModelValue> robot_model_values(const std::vector<const ModelValue*>& values, const RobotDescription& robot,
                                           const sim::PlanarLegModel& start) {
  std::vector<ModelValue> out;
  for (const ModelValue* v : values) {
    robot_value_site(*v, robot);
    ModelValue mine = *v;
    const double value = v->get(start);
    if (scales_with_robot(*v) && value > 0.0) {
      mine.lower = value / 3.0;
      mine.upper = value * 3.0;
      mine.bounds_reason = fmt::format("a factor of 3 around robot '{}''s own {} (Morti's bounds are that around Morti's: {})",
                                       robot.name, value, v->bounds_reason);
    } else if (value > v->upper || value < v->lower) {
      // A size-free value outside Morti's range, or a size-dependent one at 0 (nothing to scale from): the
      // robot's own value is the engineer's, with its source, so the range is widened to hold it.
      mine.lower = std::min(v->lower, value);
      mine.upper = std::max(v->upper, value);
    }
    out.push_back(mine);
  }
  return out;
}

std::string default_robot_value_list(const RobotDescription& robot) {
  const auto knee = robot.drives.find("knee");
  if (knee != robot.drives.end() && knee->second.kind == Kind::kSeriesElastic) {
    return "knee_spring.stiffness_nm_per_rad,trunk.mass_kg";
  }
  if (parallel_spring_index(robot, "hip", "knee") >= 0) return "knee_parallel_spring.stiffness_nm_per_rad,trunk.mass_kg";
  return "trunk.mass_kg";
}

}  // namespace cpgmatch::calibration
