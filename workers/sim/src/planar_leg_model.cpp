#include "cpgmatch/sim/planar_leg_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/sim/physical_ranges.hpp"

namespace cpgmatch::sim {
namespace {

constexpr double kTolerance = 1e-9;

[[noreturn]] void refuse(const RobotDescription& robot, const std::string& what) {
  throw InputError(fmt::format("{}: robot '{}': {}", robot.yaml_source, robot.name, what));
}

// A joint turning about the URDF's y axis (the sagittal plane's normal); +1 for +y, -1 for -y.
int planar_axis_sign(const RobotDescription& robot, const JointDescription& j) {
  const Vec3& a = j.axis;
  if (std::abs(a.x) > kTolerance || std::abs(a.z) > kTolerance || std::abs(std::abs(a.y) - 1.0) > kTolerance) {
    refuse(robot, fmt::format("joint '{}' ({}) turns about ({}, {}, {}); a planar robot's joints turn about y", j.name,
                              j.where, a.x, a.y, a.z));
  }
  if (std::abs(j.origin.rpy.x) > kTolerance || std::abs(j.origin.rpy.z) > kTolerance) {
    refuse(robot, fmt::format("joint '{}' ({}) has roll or yaw in its origin; a planar robot's frames turn about y only",
                              j.name, j.where));
  }
  return a.y > 0.0 ? 1 : -1;
}

// The segment from a joint to the next one lies along the link's z axis (URDF pose at zero).
double segment_length(const RobotDescription& robot, const JointDescription& next) {
  const Vec3& p = next.origin.xyz;
  if (std::abs(p.x) > kTolerance || std::abs(p.y) > kTolerance || !(p.z < 0.0)) {
    refuse(robot, fmt::format("joint '{}' ({}) sits at ({}, {}, {}) in its parent link; this plant builds segments "
                              "along the link's -z axis",
                              next.name, next.where, p.x, p.y, p.z));
  }
  return -p.z;
}

const CollisionShape& toe_sphere(const RobotDescription& robot, const LinkDescription& foot) {
  for (const CollisionShape& s : foot.collisions) {
    if (s.kind == CollisionShape::Kind::kSphere) return s;
  }
  refuse(robot, fmt::format("link '{}' ({}) has no collision sphere", foot.name, foot.where));
}

SegmentModel segment_of(const LinkDescription& link, double length_m) { return {length_m, link.mass_kg}; }

// One leg's values, to compare the legs with each other.
struct LegValues {
  double hip_x, hip_pitch, femur_len, shank_len, foot_len, knee_pitch, ankle_pitch, toe_radius;
  double femur_mass, shank_mass, foot_mass, knee_lo, knee_hi, ankle_lo, ankle_hi;
  int hip_sign, knee_sign, ankle_sign;
  bool has_ankle;
};

LegValues leg_values(const RobotDescription& robot, const LegDescription& leg) {
  const JointDescription& hip = robot.joint(leg.hip_joint);
  const JointDescription& knee = robot.joint(leg.knee_joint);
  LegValues v{};
  v.has_ankle = !leg.ankle_joint.empty();
  v.hip_sign = planar_axis_sign(robot, hip);
  v.knee_sign = planar_axis_sign(robot, knee);
  v.hip_x = hip.origin.xyz.x;
  v.hip_pitch = hip.origin.rpy.y;
  if (std::abs(hip.origin.xyz.z) > kTolerance) {
    refuse(robot, fmt::format("joint '{}' ({}) is {} m above the trunk's origin; this plant puts hips at its height", hip.name,
                              hip.where, hip.origin.xyz.z));
  }
  v.femur_len = segment_length(robot, knee);
  const LinkDescription& foot = robot.link(leg.foot_link);
  const CollisionShape& toe = toe_sphere(robot, foot);
  if (std::abs(toe.origin.xyz.x) > kTolerance || std::abs(toe.origin.xyz.y) > kTolerance || !(toe.origin.xyz.z < 0.0)) {
    refuse(robot, fmt::format("the toe sphere of link '{}' ({}) must sit on the link's -z axis", foot.name, foot.where));
  }
  v.toe_radius = toe.radius_m;
  v.knee_pitch = knee.origin.rpy.y;
  v.femur_mass = robot.link(hip.child_link).mass_kg;
  v.shank_mass = robot.link(knee.child_link).mass_kg;
  if (!knee.limited) refuse(robot, fmt::format("knee '{}' ({}) needs limits (its end stops)", knee.name, knee.where));
  v.knee_lo = knee.lower;
  v.knee_hi = knee.upper;
  if (!v.has_ankle) {
    // A two-segment leg: the foot link is the shank, and the toe at its end sets the shank's length.
    v.shank_len = -toe.origin.xyz.z;
    return v;
  }
  const JointDescription& ankle = robot.joint(leg.ankle_joint);
  v.ankle_sign = planar_axis_sign(robot, ankle);
  v.shank_len = segment_length(robot, ankle);
  v.foot_len = -toe.origin.xyz.z;
  v.ankle_pitch = ankle.origin.rpy.y;
  v.foot_mass = foot.mass_kg;
  if (!ankle.limited) refuse(robot, fmt::format("ankle '{}' ({}) needs limits (its end stops)", ankle.name, ankle.where));
  v.ankle_lo = ankle.lower;
  v.ankle_hi = ankle.upper;
  return v;
}

bool same(double a, double b) { return std::abs(a - b) <= kTolerance * std::max(1.0, std::abs(a)); }

void require_alike(const RobotDescription& robot, const LegValues& a, const LegValues& b, const std::string& leg) {
  const std::pair<const char*, std::pair<double, double>> fields[] = {
      {"hip mount angle", {a.hip_pitch, b.hip_pitch}}, {"femur length", {a.femur_len, b.femur_len}},
      {"shank length", {a.shank_len, b.shank_len}},     {"foot length", {a.foot_len, b.foot_len}},
      {"knee standing angle", {a.knee_pitch, b.knee_pitch}}, {"ankle standing angle", {a.ankle_pitch, b.ankle_pitch}},
      {"toe radius", {a.toe_radius, b.toe_radius}},     {"femur mass", {a.femur_mass, b.femur_mass}},
      {"shank mass", {a.shank_mass, b.shank_mass}},     {"foot mass", {a.foot_mass, b.foot_mass}},
      {"knee limits", {a.knee_lo + 7 * a.knee_hi, b.knee_lo + 7 * b.knee_hi}},
      {"ankle limits", {a.ankle_lo + 7 * a.ankle_hi, b.ankle_lo + 7 * b.ankle_hi}},
      {"ankle (has one)", {a.has_ankle ? 1.0 : 0.0, b.has_ankle ? 1.0 : 0.0}},
      {"joint axes", {a.hip_sign + 3.0 * a.knee_sign + 9.0 * a.ankle_sign, b.hip_sign + 3.0 * b.knee_sign + 9.0 * b.ankle_sign}}};
  for (const auto& [name, values] : fields) {
    if (!same(values.first, values.second)) {
      refuse(robot, fmt::format("leg {}'s {} differs from leg {}'s; this plant builds legs that are alike", leg, name,
                                robot.legs.front().name));
    }
  }
}

}  // namespace

PlanarLegModel planar_leg_model(const RobotDescription& robot) {
  const LegValues first = leg_values(robot, robot.legs.front());
  for (std::size_t i = 1; i < robot.legs.size(); ++i) {
    require_alike(robot, first, leg_values(robot, robot.legs[i]), robot.legs[i].name);
  }

  PlanarLegModel m;
  const LinkDescription& trunk = robot.link(robot.root_link);
  m.trunk_mass_kg = trunk.mass_kg;
  const auto box = std::find_if(trunk.collisions.begin(), trunk.collisions.end(),
                                [](const CollisionShape& s) { return s.kind == CollisionShape::Kind::kBox; });
  if (box == trunk.collisions.end()) refuse(robot, fmt::format("the trunk '{}' ({}) needs a collision box", trunk.name, trunk.where));
  m.trunk_length_m = box->box_size_m.x;
  m.trunk_depth_m = box->box_size_m.y;
  m.trunk_height_m = box->box_size_m.z;
  for (const LegDescription& leg : robot.legs) m.hip_x_m.push_back(robot.joint(leg.hip_joint).origin.xyz.x);
  const auto [hind_x, front_x] = std::minmax_element(m.hip_x_m.begin(), m.hip_x_m.end());
  m.hip_spacing_m = *front_x - *hind_x;  // informational: the layout is hip_x_m
  m.planar = robot.planar;
  if (!robot.planar) {
    // A robot standing on its own needs feet on both sides of its trunk: with every hip on one line (or one
    // side) its support polygon has no width, and it falls sideways whatever the gait.
    bool left = false, right = false;
    for (const LegDescription& leg : robot.legs) {
      const double y = robot.joint(leg.hip_joint).origin.xyz.y;
      m.hip_lateral_m.push_back(y);
      left = left || y > kTolerance;
      right = right || y < -kTolerance;
    }
    if (!left || !right) {
      refuse(robot, "planar: false needs hips on both sides of the trunk (URDF y > 0 and y < 0): a robot whose feet "
                    "stand on one line cannot stand on its own; keep planar: true for a robot on a rail or boom");
    }
  }

  m.femur = segment_of(robot.link(robot.joint(robot.legs[0].hip_joint).child_link), first.femur_len);
  m.shank = segment_of(robot.link(robot.joint(robot.legs[0].knee_joint).child_link), first.shank_len);
  m.has_ankle = first.has_ankle;
  if (first.has_ankle) m.foot = segment_of(robot.link(robot.legs[0].foot_link), first.foot_len);
  m.toe_radius_m = first.toe_radius;

  // URDF pitch turns a link about +y, which moves a segment hanging along -z backwards; the plant's angles
  // are + forward (counter-clockwise seen with x forward and up up), i.e. about -y.
  if (first.hip_sign != -1) refuse(robot, "a hip's axis must be -y (+ swings the foot forward)");
  if (first.knee_sign != 1) refuse(robot, "a knee's axis must be +y (+ flexes the knee)");
  m.femur_mount_angle_rad = -first.hip_pitch;
  m.knee_stand_flexion_rad = first.knee_pitch;
  m.knee_min_flexion_rad = m.knee_stand_flexion_rad + first.knee_lo;
  m.knee_max_flexion_rad = m.knee_stand_flexion_rad + first.knee_hi;
  if (first.has_ankle) {
    if (!same(first.ankle_pitch, -first.knee_pitch)) {
      refuse(robot, "the foot must stand parallel to the femur (ankle origin pitch = -knee origin pitch)");
    }
    if (!same(first.ankle_lo, -first.ankle_hi)) refuse(robot, "the ankle's limits must be symmetric about its standing pose");
    m.ankle_range_rad = first.ankle_hi;
  }

  const DriveDescription& hip = robot.drives.at("hip");
  const DriveDescription& knee = robot.drives.at("knee");
  if (hip.kind != DriveDescription::Kind::kPositionPd) refuse(robot, "drives.hip must be position_pd for this plant");

  if (robot.drives.count("ankle") && robot.drives.at("ankle").kind != DriveDescription::Kind::kPassive) {
    refuse(robot, "drives.ankle must be passive for this plant");
  }
  const MotorDescription& hm = robot.motors.at(hip.motor);
  m.hip_motor = {hm.stall_torque_nm, hm.no_load_speed_rad_s, hip.kp_nm_per_rad, hip.kd_nm_s_per_rad,
                 hm.coulomb_friction_nm, hm.viscous_friction_nm_s_per_rad, hm.reflected_inertia_kg_m2};
  const MotorDescription& km = robot.motors.at(knee.motor);
  m.knee_joint_friction_nm = knee.joint_friction_nm;
  if (knee.kind == DriveDescription::Kind::kSeriesElastic) {
    m.knee_drive = PlanarLegModel::KneeDrive::kSeriesElastic;
    m.knee_motor = {km.stall_torque_nm, km.no_load_speed_rad_s, 0.0, 0.0, 0.0, 0.0, 0.0};
    m.knee_motor_bandwidth_per_s = knee.bandwidth_per_s;
    m.knee_spring = {knee.series_spring.stiffness_nm_per_rad, knee.series_spring.damping_nm_s_per_rad};
  } else {
    // Driven directly: the gearbox's friction and reflected inertia load the knee as the hip's load the hip.
    m.knee_drive = PlanarLegModel::KneeDrive::kPositionPd;
    m.knee_motor = {km.stall_torque_nm, km.no_load_speed_rad_s, knee.kp_nm_per_rad, knee.kd_nm_s_per_rad,
                    km.coulomb_friction_nm, km.viscous_friction_nm_s_per_rad, km.reflected_inertia_kg_m2};
  }

  // Parallel springs this plant builds: foot to femur (biarticular, legs with an ankle) and across the knee.
  m.biarticular_spring = {0.0, 0.0};
  bool biarticular_seen = false;
  for (const ParallelSpringDescription& s : robot.parallel_springs) {
    const auto pair = [&](const char* a, const char* b) {
      return (s.from_role == a && s.to_role == b) || (s.from_role == b && s.to_role == a);
    };
    if (pair("hip", "ankle")) {
      m.biarticular_spring = {s.spring.stiffness_nm_per_rad, s.spring.damping_nm_s_per_rad};
      biarticular_seen = true;
    } else if (pair("hip", "knee")) {
      m.knee_parallel_spring = {s.spring.stiffness_nm_per_rad, s.spring.damping_nm_s_per_rad};
    } else {
      refuse(robot, fmt::format("parallel spring '{}' ({} to {}): this plant builds foot-to-femur and knee springs", s.name,
                                s.from_role, s.to_role));
    }
  }
  if (m.has_ankle && !biarticular_seen) {
    refuse(robot, "a leg with a passive ankle needs a parallel spring from the hip's link (femur) to the ankle's (foot)");
  }
  m.contact = {robot.contact.friction, robot.contact.stiffness_n_per_m, robot.contact.damping_n_s_per_m};
  m.foot_sensor = {robot.foot_sensor.sensitivity, robot.foot_sensor.time_constant_s};
  m.physics_rate_hz = robot.physics_rate_hz;
  m.gravity_m_s2 = robot.gravity_m_s2;
  // The same physical ranges as a model file's (physical_ranges.hpp): no absurd value reaches ODE.
  if (const auto problem = check_physical_ranges(m)) {
    refuse(robot, fmt::format("{}.{}: {}", problem->section, problem->key, problem->message));
  }
  return m;
}

double standing_trunk_height_m(const RobotDescription& robot) {
  // Forward kinematics in the sagittal plane (x forward, z up) at every joint's zero: each frame's position
  // and its pitch about +y, down every leg to its toe sphere.
  double lowest = std::numeric_limits<double>::infinity();
  for (const LegDescription& leg : robot.legs) {
    double x = 0.0, z = 0.0, pitch = 0.0;
    auto descend = [&](const Vec3& p, double joint_pitch) {
      // A point p in the current frame: rotate by pitch about +y (x' = x cos + z sin, z' = -x sin + z cos).
      x += p.x * std::cos(pitch) + p.z * std::sin(pitch);
      z += -p.x * std::sin(pitch) + p.z * std::cos(pitch);
      pitch += joint_pitch;
    };
    std::vector<const JointDescription*> chain{&robot.joint(leg.hip_joint), &robot.joint(leg.knee_joint)};
    if (!leg.ankle_joint.empty()) chain.push_back(&robot.joint(leg.ankle_joint));
    for (const JointDescription* j : chain) descend(j->origin.xyz, j->origin.rpy.y);
    for (const CollisionShape& s : robot.link(leg.foot_link).collisions) {
      if (s.kind != CollisionShape::Kind::kSphere) continue;
      double tx = x, tz = z;
      tx += s.origin.xyz.x * std::cos(pitch) + s.origin.xyz.z * std::sin(pitch);
      tz += -s.origin.xyz.x * std::sin(pitch) + s.origin.xyz.z * std::cos(pitch);
      (void)tx;
      lowest = std::min(lowest, tz - s.radius_m);
    }
  }
  // OdePlant lets the robot start 1 mm above the ground and settle.
  return -lowest + 0.001;
}

}  // namespace cpgmatch::sim
