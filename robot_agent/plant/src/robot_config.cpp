#include "cpgmatch/robot/robot_config.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <cstdlib>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/text.hpp"
#include "cpgmatch/yaml_reader.hpp"
#include "cpgmatch/robot/motor_factory.hpp"

namespace cpgmatch::robot {
namespace {

// The CAN ids one owner (a joint's motor, a sensor) uses, for the one-id-one-owner check.
struct IdClaim {
  bool extended = false;
  std::uint32_t first = 0, last = 0;
  std::string owner;  // "FL_hip (odrive node 1)"
};

class IdRegistry {
 public:
  void claim(const YamlReader& at, const std::string& key, IdClaim c) {
    for (const IdClaim& other : claims_) {
      if (other.extended == c.extended && c.first <= other.last && other.first <= c.last) {
        at.fail(key, fmt::format("CAN id{} {} of {} {} already used by {}", c.first == c.last ? "" : "s", range(c), c.owner,
                                 c.first == c.last ? "is" : "are", other.owner));
      }
    }
    claims_.push_back(std::move(c));
  }

 private:
  static std::string range(const IdClaim& c) {
    return c.first == c.last ? fmt::format("0x{:X}", c.first) : fmt::format("0x{:X}..0x{:X}", c.first, c.last);
  }
  std::vector<IdClaim> claims_;
};

void check_ranges_mit(const YamlReader& j, const JointConfig& c, const MitRanges& ranges) {
  for (const double joint : {c.position_min_rad, c.position_max_rad}) {
    if (std::abs(c.to_motor_position(joint)) > ranges.position_max_rad) {
      j.fail(joint == c.position_min_rad ? "position_min_rad" : "position_max_rad",
             fmt::format("is {} rad at the motor, outside the protocol's +-{} rad", c.to_motor_position(joint),
                         ranges.position_max_rad));
    }
  }
  if (std::abs(c.to_motor_velocity(c.velocity_max_rad_s)) > ranges.velocity_max_rad_s) {
    j.fail("velocity_max_rad_s", fmt::format("is beyond the protocol's +-{} rad/s at the motor", ranges.velocity_max_rad_s));
  }
  if (std::abs(c.to_motor_torque(c.torque_max_nm)) > ranges.torque_max_nm) {
    j.fail("torque_max_nm", fmt::format("is beyond the protocol's +-{} N m at the motor", ranges.torque_max_nm));
  }
  if (c.to_motor_kp(c.kp_nm_per_rad) > ranges.kp_max_nm_per_rad) {
    j.fail("kp_nm_per_rad", fmt::format("must be >= 0 and at most {} at the motor", ranges.kp_max_nm_per_rad));
  }
  if (c.to_motor_kd(c.kd_nm_s_per_rad) > ranges.kd_max_nm_s_per_rad) {
    j.fail("kd_nm_s_per_rad", fmt::format("must be >= 0 and at most {} at the motor", ranges.kd_max_nm_s_per_rad));
  }
}

MitRanges load_mit_ranges(const YamlReader& m, MitRanges g) {
  m.reject_unknown_keys({"position_max_rad", "velocity_max_rad_s", "kp_max_nm_per_rad", "kd_max_nm_s_per_rad", "torque_max_nm"});
  g.position_max_rad = m.get_double_in("position_max_rad", g.position_max_rad, 0.1, 1000.0);
  g.velocity_max_rad_s = m.get_double_in("velocity_max_rad_s", g.velocity_max_rad_s, 0.1, 1000.0);
  g.kp_max_nm_per_rad = m.get_double_in("kp_max_nm_per_rad", g.kp_max_nm_per_rad, 0.1, 10000.0);
  g.kd_max_nm_s_per_rad = m.get_double_in("kd_max_nm_s_per_rad", g.kd_max_nm_s_per_rad, 0.01, 1000.0);
  g.torque_max_nm = m.get_double_in("torque_max_nm", g.torque_max_nm, 0.1, 1000.0);
  return g;
}

JointConfig load_joint(const YamlReader& j, const std::string& name, const RobotConfig& robot) {
  j.reject_unknown_keys({"leg", "role", "protocol", "node_id", "gear_ratio", "direction", "zero_offset_rad",
                         "position_min_rad", "position_max_rad", "velocity_max_rad_s", "torque_max_nm", "kp_nm_per_rad",
                         "kd_nm_s_per_rad", "motor_ranges", "torque_constant_nm_per_a", "request_iq", "iq_every",
                         "servo_kp_nm_per_rad", "servo_kd_nm_s_per_rad", "safety"});
  JointConfig c;
  c.name = name;
  c.origin = j.where();
  if (!j.has("leg")) j.fail("leg", fmt::format("is missing (the leg this joint belongs to: one of {})", fmt::join(robot.legs, ", ")));
  const std::string leg = j.require_string("leg");
  const auto it = std::find(robot.legs.begin(), robot.legs.end(), leg);
  if (it == robot.legs.end()) j.fail("leg", fmt::format("'{}' is not one of the robot's legs ({})", leg, fmt::join(robot.legs, ", ")));
  c.leg = static_cast<int>(it - robot.legs.begin());
  if (!j.has("role")) j.fail("role", "is missing (hip or knee)");
  const std::string role = j.require_string("role");
  if (role != "hip" && role != "knee") j.fail("role", fmt::format("'{}' is not hip or knee", role));
  c.role = role == "hip" ? JointRole::kHip : JointRole::kKnee;
  c.protocol = j.get_string("protocol", robot.protocol);
  if (!is_motor_protocol(c.protocol)) j.fail("protocol", fmt::format("'{}' is not a motor protocol (known: mit, odrive, moteus)", c.protocol));
  if (!j.has("node_id")) j.fail("node_id", "is missing (every joint needs its motor's CAN node id)");
  if (c.protocol == "mit") c.node_id = static_cast<std::uint32_t>(j.get_int_in("node_id", 0, 1, 255));
  if (c.protocol == "odrive") c.node_id = static_cast<std::uint32_t>(j.get_int_in("node_id", 0, 0, static_cast<int>(kOdriveMaxNode)));
  if (c.protocol == "moteus") c.node_id = static_cast<std::uint32_t>(j.get_int_in("node_id", 0, 1, static_cast<int>(kMoteusMaxId)));
  c.gear_ratio = j.get_double("gear_ratio", 1.0);
  if (!(c.gear_ratio > 0.0 && c.gear_ratio <= 1000.0)) j.fail("gear_ratio", "must be in (0, 1000]");
  c.direction = j.get_int("direction", 1);
  if (c.direction != 1 && c.direction != -1) j.fail("direction", "must be 1 or -1");
  c.zero_offset_rad = j.get_double_in("zero_offset_rad", 0.0, -2.0 * M_PI, 2.0 * M_PI);
  c.position_min_rad = j.require_double("position_min_rad");
  c.position_max_rad = j.require_double("position_max_rad");
  if (!(c.position_min_rad < c.position_max_rad)) j.fail("position_max_rad", "must be above position_min_rad");
  c.velocity_max_rad_s = j.require_double("velocity_max_rad_s");
  if (!(c.velocity_max_rad_s > 0.0)) j.fail("velocity_max_rad_s", "must be > 0");
  c.torque_max_nm = j.require_double("torque_max_nm");
  if (!(c.torque_max_nm > 0.0)) j.fail("torque_max_nm", "must be > 0");
  c.kp_nm_per_rad = j.require_double("kp_nm_per_rad");
  c.kd_nm_s_per_rad = j.require_double("kd_nm_s_per_rad");
  if (!(c.kp_nm_per_rad >= 0.0)) j.fail("kp_nm_per_rad", "must be >= 0");
  if (!(c.kd_nm_s_per_rad >= 0.0)) j.fail("kd_nm_s_per_rad", "must be >= 0");

  if (j.has("safety")) {
    const YamlReader s = j.child("safety");
    s.reject_unknown_keys({"feedback_timeout_s", "safe_damping_nm_s_per_rad"});
    // Per joint: a slower feedback (ODrive's cyclic estimates) may need a longer timeout, never beyond the
    // 20-ms safety target on a robot.
    if (s.has("feedback_timeout_s")) {
      c.feedback_timeout_s = s.get_double_in("feedback_timeout_s", 0.0, 0.002, robot.emulator_only ? 1.0 : 0.015);
    }
    if (s.has("safe_damping_nm_s_per_rad")) c.safe_damping_nm_s_per_rad = s.get_double_in("safe_damping_nm_s_per_rad", 0.0, 0.0, 10.0);
  }

  const bool has_mit = j.has("motor_ranges"), has_odrive = j.has("torque_constant_nm_per_a") || j.has("request_iq") || j.has("iq_every"),
             has_moteus = j.has("servo_kp_nm_per_rad") || j.has("servo_kd_nm_s_per_rad");
  if (has_mit && c.protocol != "mit") j.fail("motor_ranges", fmt::format("is for mit joints, this one is {}", c.protocol));
  if (has_odrive && c.protocol != "odrive") j.fail(j.has("request_iq") ? "request_iq" : "torque_constant_nm_per_a", fmt::format("is for odrive joints, this one is {}", c.protocol));
  if (has_moteus && c.protocol != "moteus") j.fail(j.has("servo_kp_nm_per_rad") ? "servo_kp_nm_per_rad" : "servo_kd_nm_s_per_rad", fmt::format("is for moteus joints, this one is {}", c.protocol));

  if (c.protocol == "mit") {
    c.mit_ranges = has_mit ? load_mit_ranges(j.child("motor_ranges"), robot.ranges) : robot.ranges;
    check_ranges_mit(j, c, c.mit_ranges);
  } else if (c.protocol == "odrive") {
    c.odrive.request_iq = j.get_bool("request_iq", true);
    c.odrive.torque_constant_nm_per_a = j.get_double("torque_constant_nm_per_a", 0.0);
    c.odrive.iq_every = static_cast<std::uint32_t>(j.get_int_in("iq_every", 1, 1, 1000));
    if (c.odrive.request_iq && !(c.odrive.torque_constant_nm_per_a > 0.0)) {
      j.fail("torque_constant_nm_per_a", "is missing or not > 0 (the ODrive's motor torque constant, 8.27 / KV, turns its Iq into torque)");
    }
    if (c.kp_nm_per_rad > 0.0 && !(c.kd_nm_s_per_rad > 0.0)) {
      j.fail("kd_nm_s_per_rad", "must be > 0 when kp_nm_per_rad is: ODrive's cascade makes kp = vel_gain x pos_gain with vel_gain = kd");
    }
    if (std::abs(c.to_motor_torque(c.torque_max_nm)) > kOdriveFeedForwardMax) {
      j.fail("torque_max_nm", fmt::format("is beyond Set_Input_Pos' torque feed-forward (+-{} N m at the motor)", kOdriveFeedForwardMax));
    }
    if (odrive_rad_to_rev(std::abs(c.to_motor_velocity(c.velocity_max_rad_s))) > kOdriveFeedForwardMax) {
      j.fail("velocity_max_rad_s", fmt::format("is beyond Set_Input_Pos' velocity feed-forward (+-{} rev/s at the motor)", kOdriveFeedForwardMax));
    }
  } else {
    c.moteus.servo_kp_nm_per_rad = j.require_double("servo_kp_nm_per_rad");
    c.moteus.servo_kd_nm_s_per_rad = j.require_double("servo_kd_nm_s_per_rad");
    c.moteus.host_id = robot.host_id;
    if (!(c.moteus.servo_kp_nm_per_rad > 0.0)) j.fail("servo_kp_nm_per_rad", "must be > 0 (the servo's configured servo.pid_position.kp / 2 pi)");
    if (!(c.moteus.servo_kd_nm_s_per_rad > 0.0)) j.fail("servo_kd_nm_s_per_rad", "must be > 0 (the servo's configured servo.pid_position.kd / 2 pi)");
    // A command carries only kp_scale and kd_scale in [0, 1]: the joint cannot be stiffer than the servo.
    if (c.to_motor_kp(c.kp_nm_per_rad) > c.moteus.servo_kp_nm_per_rad * (1 + 1e-9)) {
      j.fail("kp_nm_per_rad", fmt::format("is {} N m/rad at the motor, above the servo's own kp {} (kp_scale would exceed 1)",
                                          c.to_motor_kp(c.kp_nm_per_rad), c.moteus.servo_kp_nm_per_rad));
    }
    for (const double kd : {c.kd_nm_s_per_rad, robot.safe_damping(c)}) {
      if (c.to_motor_kd(kd) > c.moteus.servo_kd_nm_s_per_rad * (1 + 1e-9)) {
        j.fail(kd == c.kd_nm_s_per_rad ? "kd_nm_s_per_rad" : "safety", fmt::format("damping {} N m s/rad at the motor is above the servo's own kd {} (kd_scale would exceed 1)",
                                            c.to_motor_kd(kd), c.moteus.servo_kd_nm_s_per_rad));
      }
    }
  }
  return c;
}

// The ids a joint's motor uses on the bus, for the one-owner check.
std::vector<IdClaim> motor_claims(const JointConfig& c) {
  const std::string owner = fmt::format("{} ({} node {})", c.name, c.protocol, c.node_id);
  if (c.protocol == "odrive") return {{false, odrive_id(c.node_id, 0), odrive_id(c.node_id, 0x1F), owner}};
  if (c.protocol == "moteus") {
    return {{true, moteus_reply_id(c.node_id, c.moteus.host_id), moteus_reply_id(c.node_id, c.moteus.host_id), owner},
            {true, moteus_command_id(c.moteus.host_id, c.node_id), moteus_command_id(c.moteus.host_id, c.node_id), owner}};
  }
  return {{false, c.node_id, c.node_id, owner}};
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

const char* to_string(JointRole role) { return role == JointRole::kHip ? "hip" : "knee"; }

int RobotConfig::joint_index(int leg, JointRole role) const {
  for (std::size_t j = 0; j < joints.size(); ++j) {
    if (joints[j].leg == leg && joints[j].role == role) return static_cast<int>(j);
  }
  throw std::out_of_range(fmt::format("leg {} has no {} joint", leg, to_string(role)));
}

bool RobotConfig::needs_fd() const {
  return std::any_of(joints.begin(), joints.end(), [](const JointConfig& j) { return j.protocol == "moteus"; });
}

std::optional<std::string> RobotConfig::plant_mismatch() const {
  if (leg_count() >= 1 && static_cast<std::size_t>(leg_count()) <= kMaxLegs) return std::nullopt;
  return fmt::format("{} describes {} legs; the controller and the Plant drive 1 to {}", source, leg_count(), kMaxLegs);
}

std::optional<std::string> RobotConfig::study_robot_mismatch(const RobotDescription& study_robot) const {
  std::vector<std::string> theirs;
  for (const LegDescription& leg : study_robot.legs) {
    theirs.push_back(leg.hip_joint);
    theirs.push_back(leg.knee_joint);
  }
  std::vector<std::string> ours;
  std::set<std::string> protocols;
  for (const JointConfig& j : joints) {
    ours.push_back(j.name);
    protocols.insert(j.protocol);
  }
  std::sort(theirs.begin(), theirs.end());
  std::sort(ours.begin(), ours.end());
  const std::string body = fmt::format("this agent drives {} ({}: {} legs, joints {}; protocol {})",
                                       robot.empty() ? "an unnamed robot" : "'" + robot + "'", source, leg_count(),
                                       fmt::join(ours, ", "), fmt::join(protocols, ", "));
  if (!robot.empty() && robot != study_robot.name) {
    return fmt::format("the study is for robot '{}'; {}", study_robot.name, body);
  }
  if (theirs != ours || study_robot.legs.size() != legs.size()) {
    return fmt::format("the study's robot '{}' has {} legs with the driven joints {}; {}", study_robot.name,
                       study_robot.legs.size(), fmt::join(theirs, ", "), body);
  }
  return std::nullopt;
}

std::unique_ptr<MotorProtocol> make_joint_protocol(const JointConfig& joint) {
  ProtocolSettings settings;
  settings.host_id = joint.protocol == "moteus" ? joint.moteus.host_id : 0;
  settings.mit = joint.mit_ranges;
  settings.odrive = joint.odrive;
  settings.moteus = joint.moteus;
  return make_motor_protocol(joint.protocol, joint.node_id, settings);
}

RobotConfig load_robot_config(const std::string& path) {
  const YamlReader r = YamlReader::from_file(path);
  r.reject_unknown_keys({"robot", "emulator_only", "protocol", "bitrate", "data_bitrate", "host_id", "control_rate_hz", "motor_ranges",
                         "legs", "joints", "feet", "trunk_sensor", "safety"});
  RobotConfig c;
  c.source = path;
  c.robot = r.get_string("robot", "");
  if (r.has("robot")) {
    if (const auto problem = name_problem(c.robot, 63)) r.fail("robot", *problem);
  }
  c.emulator_only = r.get_bool("emulator_only", false);
  c.protocol = r.get_string("protocol", c.protocol);
  if (!is_motor_protocol(c.protocol)) r.fail("protocol", fmt::format("'{}' is not a motor protocol (known: mit, odrive, moteus)", c.protocol));
  (void)r.get_int_in("bitrate", 1000000, 10000, 1000000);  // set on the interface (ip link), documented here
  (void)r.get_int_in("data_bitrate", 5000000, 1000000, 8000000);  // CAN-FD data phase, likewise
  c.host_id = static_cast<std::uint32_t>(r.get_int_in("host_id", 0, 0, static_cast<int>(can::kMaxStandardId)));
  c.control_rate_hz = r.get_double_in("control_rate_hz", c.control_rate_hz, 50.0, 2000.0);
  if (r.has("motor_ranges")) c.ranges = load_mit_ranges(r.child("motor_ranges"), c.ranges);
  // Safety first: joints take its values as their defaults.
  if (r.has("safety")) load_safety(r.child("safety"), c.safety, c.emulator_only);

  // The legs, in the controller's order.
  if (!r.has("legs")) r.fail("legs", "is missing (the leg names in the controller's order, e.g. [FL, FR, HL, HR])");
  const YAML::Node legs = r.node()["legs"];
  if (!legs.IsSequence() || legs.size() == 0) r.fail("legs", "must be a non-empty list of leg names");
  for (const auto& leg : legs) {
    const std::string name = leg.IsScalar() ? leg.Scalar() : "";
    if (name.empty()) r.fail("legs", "every leg must be a name");
    if (std::find(c.legs.begin(), c.legs.end(), name) != c.legs.end()) r.fail("legs", fmt::format("leg '{}' is listed twice", name));
    c.legs.push_back(name);
  }

  IdRegistry ids;
  const YamlReader joints = r.child("joints");
  joints.check_keys();
  std::vector<std::array<int, 2>> owner(c.legs.size(), {-1, -1});  // per leg: its hip's and knee's joint index
  bool mit_replies_claimed = false;
  for (const auto& entry : joints.node()) {
    const std::string name = entry.first.Scalar();
    const YamlReader j = joints.child(name);
    JointConfig joint = load_joint(j, name, c);
    int& slot = owner[joint.leg][joint.role == JointRole::kHip ? 0 : 1];
    if (slot >= 0) {
      j.fail("role", fmt::format("leg {} already has a {} ({})", c.legs[joint.leg], to_string(joint.role), c.joints[slot].name));
    }
    slot = static_cast<int>(c.joints.size());
    for (IdClaim& claim : motor_claims(joint)) ids.claim(j, "node_id", std::move(claim));
    if (joint.protocol == "mit" && !mit_replies_claimed) {
      ids.claim(r, "host_id", {false, c.host_id, c.host_id, "the MIT motors' replies (host_id)"});
      mit_replies_claimed = true;
    }
    c.joints.push_back(std::move(joint));
  }
  for (std::size_t leg = 0; leg < c.legs.size(); ++leg) {
    for (const JointRole role : {JointRole::kHip, JointRole::kKnee}) {
      if (owner[leg][role == JointRole::kHip ? 0 : 1] < 0) {
        joints.fail("", fmt::format("leg {} has no {} joint (every leg needs one with 'leg: {}, role: {}')", c.legs[leg],
                                    to_string(role), c.legs[leg], to_string(role)));
      }
    }
  }

  const YamlReader feet = r.child("feet");
  feet.check_keys();
  for (const auto& entry : feet.node()) {
    const std::string name = entry.first.Scalar();
    if (std::find(c.legs.begin(), c.legs.end(), name) == c.legs.end()) {
      feet.fail(name, fmt::format("is not one of the robot's legs ({})", fmt::join(c.legs, ", ")));
    }
  }
  for (const std::string& leg : c.legs) {
    if (!feet.has(leg)) feet.fail(leg, "is missing (every leg needs its foot sensor's frame id)");
    const YamlReader foot = feet.child(leg);
    foot.reject_unknown_keys({"frame_id"});
    if (!foot.has("frame_id")) foot.fail("frame_id", "is missing (the foot sensor's CAN frame id)");
    const auto id = static_cast<std::uint32_t>(foot.get_int_in("frame_id", 0, 1, static_cast<int>(can::kMaxStandardId)));
    ids.claim(foot, "frame_id", {false, id, id, leg + " foot sensor"});
    c.foot_frame_ids.push_back(id);
  }
  const YamlReader trunk = r.child("trunk_sensor");
  trunk.reject_unknown_keys({"pose_frame_id", "speed_frame_id"});
  if (!trunk.has("pose_frame_id")) trunk.fail("pose_frame_id", "is missing (the trunk sensor's pose frame id)");
  c.trunk_pose_frame_id = static_cast<std::uint32_t>(trunk.get_int_in("pose_frame_id", 0, 1, static_cast<int>(can::kMaxStandardId)));
  c.trunk_speed_frame_id = static_cast<std::uint32_t>(
      trunk.get_int_in("speed_frame_id", static_cast<int>(std::min(c.trunk_pose_frame_id + 1, can::kMaxStandardId)), 1,
                       static_cast<int>(can::kMaxStandardId)));
  if (c.trunk_speed_frame_id == c.trunk_pose_frame_id) trunk.fail("speed_frame_id", "must differ from pose_frame_id");
  ids.claim(trunk, "pose_frame_id", {false, c.trunk_pose_frame_id, c.trunk_pose_frame_id, "the trunk sensor's pose frame"});
  ids.claim(trunk, trunk.has("speed_frame_id") ? "speed_frame_id" : "pose_frame_id",
            {false, c.trunk_speed_frame_id, c.trunk_speed_frame_id, "the trunk sensor's speed frame"});
  return c;
}

std::string default_robot_config_path() {
  if (const char* env = std::getenv("CPGMATCH_CONFIG_DIR"); env && *env) return std::string(env) + "/robot/morti.yaml";
  return std::string(CPGMATCH_CONFIG_DIR) + "/robot/morti.yaml";
}

}  // namespace cpgmatch::robot
