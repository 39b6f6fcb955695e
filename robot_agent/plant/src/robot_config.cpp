#include "cpgmatch/robot/robot_config.hpp"

#include <cmath>
#include <cstdlib>
#include <set>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch::robot {
namespace {

// Every joint must be described: the four legs' hip and knee.
std::string joint_name(int leg, bool hip) { return fmt::format("{}_{}", kHardwareLegNames[leg], hip ? "hip" : "knee"); }

JointConfig load_joint(const YamlReader& j, const std::string& name, const MitRanges& ranges) {
  j.reject_unknown_keys({"node_id", "gear_ratio", "direction", "zero_offset_rad", "position_min_rad",
                         "position_max_rad", "velocity_max_rad_s", "torque_max_nm", "kp_nm_per_rad",
                         "kd_nm_s_per_rad"});
  JointConfig c;
  c.name = name;
  if (!j.has("node_id")) j.fail("node_id", "is missing (every joint needs its motor's CAN node id)");
  c.node_id = static_cast<std::uint32_t>(j.get_int_in("node_id", 0, 1, 255));
  c.gear_ratio = j.get_double("gear_ratio", 1.0);
  if (!(c.gear_ratio > 0.0 && c.gear_ratio <= 1000.0)) j.fail("gear_ratio", "must be in (0, 1000]");
  c.direction = j.get_int("direction", 1);
  if (c.direction != 1 && c.direction != -1) j.fail("direction", "must be 1 or -1");
  c.zero_offset_rad = j.get_double_in("zero_offset_rad", 0.0, -2.0 * M_PI, 2.0 * M_PI);
  c.position_min_rad = j.require_double("position_min_rad");
  c.position_max_rad = j.require_double("position_max_rad");
  if (!(c.position_min_rad < c.position_max_rad)) j.fail("position_max_rad", "must be above position_min_rad");
  for (const double joint : {c.position_min_rad, c.position_max_rad}) {
    if (std::abs(c.to_motor_position(joint)) > ranges.position_max_rad) {
      j.fail(joint == c.position_min_rad ? "position_min_rad" : "position_max_rad",
             fmt::format("is {} rad at the motor, outside the protocol's +-{} rad", c.to_motor_position(joint),
                         ranges.position_max_rad));
    }
  }
  c.velocity_max_rad_s = j.require_double("velocity_max_rad_s");
  if (!(c.velocity_max_rad_s > 0.0)) j.fail("velocity_max_rad_s", "must be > 0");
  if (std::abs(c.to_motor_velocity(c.velocity_max_rad_s)) > ranges.velocity_max_rad_s) {
    j.fail("velocity_max_rad_s", fmt::format("is beyond the protocol's +-{} rad/s at the motor", ranges.velocity_max_rad_s));
  }
  c.torque_max_nm = j.require_double("torque_max_nm");
  if (!(c.torque_max_nm > 0.0)) j.fail("torque_max_nm", "must be > 0");
  if (std::abs(c.to_motor_torque(c.torque_max_nm)) > ranges.torque_max_nm) {
    j.fail("torque_max_nm", fmt::format("is beyond the protocol's +-{} N m at the motor", ranges.torque_max_nm));
  }
  c.kp_nm_per_rad = j.require_double("kp_nm_per_rad");
  c.kd_nm_s_per_rad = j.require_double("kd_nm_s_per_rad");
  if (!(c.kp_nm_per_rad >= 0.0) || c.to_motor_kp(c.kp_nm_per_rad) > ranges.kp_max_nm_per_rad) {
    j.fail("kp_nm_per_rad", fmt::format("must be >= 0 and at most {} at the motor", ranges.kp_max_nm_per_rad));
  }
  if (!(c.kd_nm_s_per_rad >= 0.0) || c.to_motor_kd(c.kd_nm_s_per_rad) > ranges.kd_max_nm_s_per_rad) {
    j.fail("kd_nm_s_per_rad", fmt::format("must be >= 0 and at most {} at the motor", ranges.kd_max_nm_s_per_rad));
  }
  return c;
}

void load_safety(const YamlReader& s, SafetyConfig& c, bool emulator_only) {
  s.reject_unknown_keys({"feedback_timeout_s", "max_consecutive_overruns", "safe_damping_nm_s_per_rad",
                         "stand_ramp_speed_rad_s", "stand_tolerance_rad", "envelope"});
  // The watchdog must make the motors safe within 20 ms of the last feedback: detection plus one period.
  c.feedback_timeout_s = s.get_double_in("feedback_timeout_s", c.feedback_timeout_s, 0.002, emulator_only ? 1.0 : 0.015);
  c.max_consecutive_overruns = s.get_int_in("max_consecutive_overruns", c.max_consecutive_overruns, 1, 100);
  c.safe_damping_nm_s_per_rad = s.get_double_in("safe_damping_nm_s_per_rad", c.safe_damping_nm_s_per_rad, 0.0, 10.0);
  c.stand_ramp_speed_rad_s = s.get_double_in("stand_ramp_speed_rad_s", c.stand_ramp_speed_rad_s, 0.01, 5.0);
  c.stand_tolerance_rad = s.get_double_in("stand_tolerance_rad", c.stand_tolerance_rad, 0.0, 0.5);
  if (!s.has("envelope")) return;
  const YamlReader e = s.child("envelope");
  e.check_keys();
  for (const auto& entry : e.node()) {
    const std::string name = entry.first.Scalar();
    const ParameterInfo* info = nullptr;
    try {
      info = &parameter_info(name);
    } catch (const InputError& error) {
      e.fail(name, error.what());
    }
    const YAML::Node range = entry.second;
    if (!range.IsSequence() || range.size() != 2) e.fail(name, "must be [low, high]");
    double low = 0.0, high = 0.0;
    try {
      low = range[0].as<double>();
      high = range[1].as<double>();
    } catch (const YAML::Exception&) {
      e.fail(name, "must be [low, high] with two numbers");
    }
    if (!(low <= high)) e.fail(name, fmt::format("low {} is above high {}", low, high));
    if (low < info->low || high > info->high) {
      e.fail(name, fmt::format("[{}, {}] is outside the parameter's valid range [{}, {}]", low, high, info->low, info->high));
    }
    c.envelope[name] = {low, high};
    c.envelope_origin[name] = e.where(name);
  }
}

}  // namespace

std::optional<std::string> RobotConfig::envelope_violation(const CpgParameters& params) const {
  for (const auto& [name, range] : safety.envelope) {
    const double value = params.*(parameter_info(name).member);
    if (!(value >= range.first && value <= range.second)) {
      return fmt::format("{} = {} is outside the robot's safe envelope [{}, {}] ({})", name, value, range.first,
                         range.second, safety.envelope_origin.at(name));
    }
  }
  return std::nullopt;
}

RobotConfig load_robot_config(const std::string& path) {
  const YamlReader r = YamlReader::from_file(path);
  r.reject_unknown_keys({"emulator_only", "protocol", "bitrate", "host_id", "control_rate_hz", "motor_ranges", "joints", "feet",
                         "trunk_sensor", "safety"});
  RobotConfig c;
  c.source = path;
  c.emulator_only = r.get_bool("emulator_only", false);
  c.protocol = r.get_string("protocol", c.protocol);
  if (c.protocol != "mit") r.fail("protocol", fmt::format("'{}' is not supported (supported: mit)", c.protocol));
  (void)r.get_int_in("bitrate", 1000000, 10000, 1000000);  // set on the interface (ip link), documented here
  c.host_id = static_cast<std::uint32_t>(r.get_int_in("host_id", 0, 0, static_cast<int>(can::kMaxStandardId)));
  c.control_rate_hz = r.get_double_in("control_rate_hz", c.control_rate_hz, 50.0, 2000.0);
  if (r.has("motor_ranges")) {
    const YamlReader m = r.child("motor_ranges");
    m.reject_unknown_keys({"position_max_rad", "velocity_max_rad_s", "kp_max_nm_per_rad", "kd_max_nm_s_per_rad", "torque_max_nm"});
    auto& g = c.ranges;
    g.position_max_rad = m.get_double_in("position_max_rad", g.position_max_rad, 0.1, 1000.0);
    g.velocity_max_rad_s = m.get_double_in("velocity_max_rad_s", g.velocity_max_rad_s, 0.1, 1000.0);
    g.kp_max_nm_per_rad = m.get_double_in("kp_max_nm_per_rad", g.kp_max_nm_per_rad, 0.1, 10000.0);
    g.kd_max_nm_s_per_rad = m.get_double_in("kd_max_nm_s_per_rad", g.kd_max_nm_s_per_rad, 0.01, 1000.0);
    g.torque_max_nm = m.get_double_in("torque_max_nm", g.torque_max_nm, 0.1, 1000.0);
  }

  const YamlReader joints = r.child("joints");
  std::set<std::string> known;
  for (std::size_t leg = 0; leg < kHardwareLegs; ++leg) {
    known.insert(joint_name(leg, true));
    known.insert(joint_name(leg, false));
  }
  joints.check_keys();
  for (const auto& entry : joints.node()) {
    const std::string name = entry.first.Scalar();
    if (!known.count(name)) {
      joints.fail(name, "unknown joint (expected FL_hip, FL_knee, FR_hip, FR_knee, HL_hip, HL_knee, HR_hip, HR_knee)");
    }
  }
  std::map<std::uint32_t, std::string> node_owner;
  auto claim = [&](const YamlReader& at, const std::string& key, std::uint32_t id, const std::string& who) {
    const auto [it, fresh] = node_owner.emplace(id, who);
    if (!fresh) at.fail(key, fmt::format("node id {} is already used by {}", id, it->second));
  };
  for (std::size_t leg = 0; leg < kHardwareLegs; ++leg) {
    for (const bool hip : {true, false}) {
      const std::string name = joint_name(leg, hip);
      const YamlReader j = joints.child(name);
      JointConfig joint = load_joint(j, name, c.ranges);
      claim(j, "node_id", joint.node_id, name);
      (hip ? c.hips : c.knees)[leg] = std::move(joint);
    }
  }

  const YamlReader feet = r.child("feet");
  feet.reject_unknown_keys({"FL", "FR", "HL", "HR"});
  for (std::size_t leg = 0; leg < kHardwareLegs; ++leg) {
    const YamlReader foot = feet.child(std::string(kHardwareLegNames[leg]));
    foot.reject_unknown_keys({"node_id"});
    if (!foot.has("node_id")) foot.fail("node_id", "is missing (the foot sensor's CAN id)");
    c.foot_node_ids[leg] = static_cast<std::uint32_t>(foot.get_int_in("node_id", 0, 1, static_cast<int>(can::kMaxStandardId)));
    claim(foot, "node_id", c.foot_node_ids[leg], std::string(kHardwareLegNames[leg]) + " foot");
  }
  const YamlReader trunk = r.child("trunk_sensor");
  trunk.reject_unknown_keys({"node_id"});
  if (!trunk.has("node_id")) trunk.fail("node_id", "is missing (the trunk sensor's CAN id)");
  c.trunk_node_id = static_cast<std::uint32_t>(trunk.get_int_in("node_id", 0, 1, static_cast<int>(can::kMaxStandardId) - 1));
  claim(trunk, "node_id", c.trunk_node_id, "trunk sensor");
  claim(trunk, "node_id", c.trunk_node_id + 1, "trunk sensor (speed frame)");
  if (node_owner.count(c.host_id)) r.fail("host_id", fmt::format("{} is also a node id ({})", c.host_id, node_owner[c.host_id]));

  if (r.has("safety")) load_safety(r.child("safety"), c.safety, c.emulator_only);
  return c;
}

std::string default_robot_config_path() {
  if (const char* env = std::getenv("CPGMATCH_CONFIG_DIR"); env && *env) return std::string(env) + "/robot/morti.yaml";
  return std::string(CPGMATCH_CONFIG_DIR) + "/robot/morti.yaml";
}

}  // namespace cpgmatch::robot
