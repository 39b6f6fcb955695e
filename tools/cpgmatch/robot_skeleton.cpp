#include "robot_skeleton.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include <fmt/format.h>

namespace cpgmatch::cli {
namespace {

bool moves(const JointDescription& j) { return j.type == JointType::kRevolute || j.type == JointType::kContinuous; }

// The moving joint hanging from `link`, if exactly one does (a leg is a chain).
const JointDescription* only_moving_child(const UrdfModel& urdf, const std::string& link) {
  const JointDescription* found = nullptr;
  for (const auto& j : urdf.joints) {
    if (j.parent_link != link || !moves(j)) continue;
    if (found != nullptr) return nullptr;
    found = &j;
  }
  return found;
}

// The leg's name from its hip joint's name: "FL_hip" -> "FL", "front_left_hip_joint" -> "front_left".
std::string leg_name_from(const std::string& hip_joint, std::size_t index) {
  std::string name = hip_joint;
  for (const char* suffix : {"_hip_joint", "_hip", "_haa_joint", "_hfe_joint", "_joint", "_HAA", "_HFE"}) {
    const std::string s(suffix);
    if (name.size() > s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0) {
      name.resize(name.size() - s.size());
      break;
    }
  }
  return name.empty() ? fmt::format("leg{}", index + 1) : name;
}

}  // namespace

std::vector<GuessedLeg> guess_legs(const UrdfModel& urdf) {
  std::vector<GuessedLeg> legs;
  for (const auto& hip : urdf.joints) {
    if (hip.parent_link != urdf.root_link || !moves(hip)) continue;
    GuessedLeg leg;
    leg.hip = hip.name;
    leg.hip_x_m = hip.origin.xyz.x;
    leg.hip_y_m = hip.origin.xyz.y;
    const JointDescription* knee = only_moving_child(urdf, hip.child_link);
    leg.foot = hip.child_link;
    if (knee != nullptr) {
      leg.knee = knee->name;
      leg.foot = knee->child_link;
      if (const JointDescription* ankle = only_moving_child(urdf, knee->child_link)) {
        leg.ankle = ankle->name;
        leg.foot = ankle->child_link;
      }
    }
    legs.push_back(leg);
  }
  std::stable_sort(legs.begin(), legs.end(), [](const GuessedLeg& a, const GuessedLeg& b) {
    if (std::abs(a.hip_x_m - b.hip_x_m) > 1e-6) return a.hip_x_m > b.hip_x_m;  // front first
    return a.hip_y_m > b.hip_y_m;                                              // left (+y) first
  });
  // Groups by fore-aft rows of hips: one row "all", two "front"/"hind", three "front"/"middle"/"hind".
  std::vector<double> rows;
  for (const auto& l : legs) {
    if (std::none_of(rows.begin(), rows.end(), [&](double x) { return std::abs(x - l.hip_x_m) < 1e-6; })) rows.push_back(l.hip_x_m);
  }
  for (std::size_t i = 0; i < legs.size(); ++i) {
    legs[i].name = leg_name_from(legs[i].hip, i);
    const auto row = static_cast<std::size_t>(
        std::find_if(rows.begin(), rows.end(), [&](double x) { return std::abs(x - legs[i].hip_x_m) < 1e-6; }) - rows.begin());
    if (rows.size() == 1) legs[i].group = "all";
    else if (row == 0) legs[i].group = "front";
    else if (row + 1 == rows.size()) legs[i].group = "hind";
    else legs[i].group = rows.size() == 3 ? "middle" : fmt::format("row{}", row + 1);
  }
  return legs;
}

namespace {

// Alternating gaits for the guessed legs: left and right of a row half a cycle apart, and neighbouring
// rows swapped, which gives a trot for four legs, the tripod gait for six and alternation for two.
std::vector<double> alternating_offsets(const std::vector<GuessedLeg>& legs) {
  std::vector<double> offsets;
  std::vector<double> rows;
  for (const auto& l : legs) {
    if (std::none_of(rows.begin(), rows.end(), [&](double x) { return std::abs(x - l.hip_x_m) < 1e-6; })) rows.push_back(l.hip_x_m);
  }
  for (const auto& l : legs) {
    const auto row = std::find_if(rows.begin(), rows.end(), [&](double x) { return std::abs(x - l.hip_x_m) < 1e-6; }) - rows.begin();
    const bool left = l.hip_y_m >= 0.0;
    offsets.push_back(((row % 2 == 0) == left) ? 0.0 : 0.5);
  }
  return offsets;
}

std::string list(const std::vector<double>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += fmt::format("{}{}", i ? ", " : "", v[i]);
  return s + "]";
}

}  // namespace

std::string robot_yaml_skeleton(const UrdfModel& urdf, const std::string& urdf_file_name) {
  const std::vector<GuessedLeg> legs = guess_legs(urdf);
  std::string y;
  y += fmt::format("# robot.yaml for '{}', written by `cpgmatch robot init` from {}.\n", urdf.robot_name, urdf_file_name);
  y += "# SI units: m, kg, s, rad, N m. Every value marked FILL_IN is yours to give (with its source);\n";
  y += "# `cpgmatch robot check DIR` refuses a FILL_IN left in, naming its line. docs/your-robot.md walks through it.\n";
  y += fmt::format("name: {}\n", urdf.robot_name.empty() ? "my-robot" : urdf.robot_name);
  y += "summary: \"FILL_IN: one line: what the robot is and where its values come from\"\n";
  y += fmt::format("urdf: {}\n", urdf_file_name);
  y += "planar: true   # a rail or boom keeps the trunk in the sagittal plane; false: the robot stands on its own, free in 3D\n\n";
  y += fmt::format("# The URDF's {} links: ", urdf.links.size());
  for (std::size_t i = 0; i < urdf.links.size(); ++i) y += (i ? ", " : "") + urdf.links[i].name;
  y += fmt::format("\n# Its {} joints: ", urdf.joints.size());
  for (std::size_t i = 0; i < urdf.joints.size(); ++i) {
    y += fmt::format("{}{} ({})", i ? ", " : "", urdf.joints[i].name, to_string(urdf.joints[i].type));
  }
  y += fmt::format("\n# Trunk (root link): {}\n\n", urdf.root_link);
  y += fmt::format("# Guessed from the tree: {} leg(s), each a hip hanging from the trunk, a knee, [an ankle], a foot.\n", legs.size());
  y += "# Check every name; a foot needs a <collision> sphere in the URDF. Groups share CPG parameters.\n";
  y += "legs:\n";
  for (const auto& l : legs) {
    y += fmt::format("  - {{name: {}, group: {}, hip: {}, knee: {}{}, foot: {}}}{}\n", l.name, l.group, l.hip,
                     l.knee.empty() ? "FILL_IN" : l.knee, l.ankle.empty() ? "" : ", ankle: " + l.ankle, l.foot,
                     l.knee.empty() ? "   # FILL_IN: no single knee found after this hip" : "");
  }
  y += "\nmotors:\n";
  y += "  hip_motor:\n";
  y += "    stall_torque_nm: {value: FILL_IN, source: \"FILL_IN: datasheet, at the joint (after the gearbox)\"}\n";
  y += "    no_load_speed_rad_s: {value: FILL_IN, source: \"FILL_IN\"}\n";
  y += "    gear_ratio: {value: FILL_IN, source: \"FILL_IN\"}\n";
  y += "  knee_motor:\n";
  y += "    stall_torque_nm: {value: FILL_IN, source: \"FILL_IN\"}\n";
  y += "    no_load_speed_rad_s: {value: FILL_IN, source: \"FILL_IN\"}\n\n";
  y += "drives:\n";
  y += "  hip: {kind: position_pd, motor: hip_motor, kp_nm_per_rad: FILL_IN, kd_nm_s_per_rad: FILL_IN}\n";
  y += "  # series_elastic: the motor positions a spring's rest angle; position_pd: it drives the knee directly\n";
  y += "  knee: {kind: series_elastic, motor: knee_motor, stiffness_nm_per_rad: FILL_IN, damping_nm_s_per_rad: FILL_IN, bandwidth_per_s: FILL_IN}\n";
  const bool ankles = std::any_of(legs.begin(), legs.end(), [](const GuessedLeg& l) { return !l.ankle.empty(); });
  if (ankles) {
    y += "  ankle: {kind: passive}\n\n";
    y += "# Springs between a leg's links (e.g. a biarticular spring holding the foot parallel to the femur):\n";
    y += "parallel_springs:\n";
    y += "  - {name: FILL_IN, from: hip, to: ankle, stiffness_nm_per_rad: FILL_IN, damping_nm_s_per_rad: FILL_IN}\n";
  }
  y += "\ncontact: {friction: FILL_IN, stiffness_n_per_m: FILL_IN, damping_n_s_per_m: FILL_IN}\n";
  y += "foot_sensor: {sensitivity: 1.0, time_constant_s: 0.0}   # an ideal contact sensor; say otherwise if yours lags\n";
  y += "simulation: {physics_rate_hz: 1000.0, gravity_m_s2: 9.81}\n\n";
  y += "# Phase offsets in cycles, one per leg in the order of `legs`. Guessed: left and right of a row half a\n";
  y += "# cycle apart, neighbouring rows swapped (a trot for four legs, the tripod gait for six).\n";
  y += "gaits:\n";
  y += fmt::format("  alternating: {}\n", list(alternating_offsets(legs)));
  y += "default_gait: alternating\n\n";
  y += "presets:\n";
  y += "  default: {hip_offset: 0.0, hip_amplitude: FILL_IN, knee_amplitude: FILL_IN, frequency: FILL_IN, duty_factor_front: 0.5, duty_factor_hind: 0.5, knee_phase_shift: 0.1, overswing: 0.1}\n\n";
  y += "# The CPG parameters a study tunes (names from `cpgmatch rollout --help`'s parameters), with bounds:\n";
  y += "search_space:\n";
  y += "  hip_offset: {low: FILL_IN, high: FILL_IN, unit: rad}\n";
  y += "  hip_amplitude: {low: FILL_IN, high: FILL_IN, unit: rad}\n";
  y += "  duty_factor_front: {low: 0.3, high: 0.75}\n";
  y += "  duty_factor_hind: {low: 0.3, high: 0.75}\n";
  return y;
}

}  // namespace cpgmatch::cli
