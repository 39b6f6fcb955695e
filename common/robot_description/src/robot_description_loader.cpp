// The robot.yaml half of a robot description, and the checks that tie it to its URDF.
#include "cpgmatch/robot_description_loader.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <set>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/text.hpp"
#include "cpgmatch/yaml_reader.hpp"
#include "robot_overlay.hpp"

namespace cpgmatch {
namespace {

namespace fs = std::filesystem;

double required_positive(const YamlReader& r, const std::string& key) {
  if (!r.has(key)) r.fail(key, "is required");
  return positive_value(r, key, 0.0);
}

MotorDescription parse_motor(const YamlReader& r, const std::string& name) {
  r.reject_unknown_keys({"stall_torque_nm", "no_load_speed_rad_s", "gear_ratio", "coulomb_friction_nm",
                         "viscous_friction_nm_s_per_rad", "reflected_inertia_kg_m2", "source"});
  MotorDescription m;
  m.name = name;
  m.stall_torque_nm = required_positive(r, "stall_torque_nm");
  m.no_load_speed_rad_s = required_positive(r, "no_load_speed_rad_s");
  m.gear_ratio = positive_value(r, "gear_ratio", 1.0);
  m.coulomb_friction_nm = non_negative_value(r, "coulomb_friction_nm", 0.0);
  m.viscous_friction_nm_s_per_rad = non_negative_value(r, "viscous_friction_nm_s_per_rad", 0.0);
  m.reflected_inertia_kg_m2 = non_negative_value(r, "reflected_inertia_kg_m2", 0.0);
  return m;
}

DriveDescription parse_drive(const YamlReader& r, const std::map<std::string, MotorDescription>& motors) {
  DriveDescription d;
  const std::string kind = r.require_string("kind");
  auto check_motor = [&] {
    d.motor = r.require_string("motor");
    if (!motors.count(d.motor)) {
      std::string known;
      for (const auto& [name, m] : motors) known += (known.empty() ? "" : ", ") + name;
      r.fail("motor", fmt::format("unknown motor '{}' (the robot's motors: {})", d.motor, known.empty() ? "none" : known));
    }
  };
  if (kind == "position_pd") {
    r.reject_unknown_keys({"kind", "motor", "kp_nm_per_rad", "kd_nm_s_per_rad", "joint_friction_nm"});
    d.kind = DriveDescription::Kind::kPositionPd;
    check_motor();
    d.kp_nm_per_rad = required_positive(r, "kp_nm_per_rad");
    d.kd_nm_s_per_rad = non_negative_value(r, "kd_nm_s_per_rad", 0.0);
  } else if (kind == "series_elastic") {
    r.reject_unknown_keys({"kind", "motor", "stiffness_nm_per_rad", "damping_nm_s_per_rad", "bandwidth_per_s",
                           "joint_friction_nm"});
    d.kind = DriveDescription::Kind::kSeriesElastic;
    check_motor();
    d.series_spring.stiffness_nm_per_rad = required_positive(r, "stiffness_nm_per_rad");
    d.series_spring.damping_nm_s_per_rad = non_negative_value(r, "damping_nm_s_per_rad", 0.0);
    d.bandwidth_per_s = required_positive(r, "bandwidth_per_s");
  } else if (kind == "passive") {
    r.reject_unknown_keys({"kind", "joint_friction_nm"});
    d.kind = DriveDescription::Kind::kPassive;
  } else {
    r.fail("kind", fmt::format("unknown drive '{}' (known: position_pd, series_elastic, passive)", escape_for_message(kind)));
  }
  d.joint_friction_nm = non_negative_value(r, "joint_friction_nm", 0.0);
  return d;
}

// Index of a YAML sequence element's reader.
YamlReader element(const YamlReader& seq, std::size_t i, const std::string& key) {
  return YamlReader(seq.node()[key][i], seq.source(), fmt::format("{}[{}]", seq.field(key), i));
}

const JointDescription& require_joint(const YamlReader& r, const std::string& key, const RobotDescription& robot) {
  const std::string name = r.require_string(key);
  if (const JointDescription* j = robot.find_joint(name)) return *j;
  r.fail(key, fmt::format("joint '{}' is not in {}", escape_for_message(name), robot.urdf_source));
}

void require_moving(const YamlReader& r, const std::string& key, const JointDescription& j) {
  if (j.type != JointType::kRevolute && j.type != JointType::kContinuous) {
    r.fail(key, fmt::format("joint '{}' ({}) is {}; a leg's joints must be revolute or continuous", j.name, j.where,
                            to_string(j.type)));
  }
}

void parse_legs(const YamlReader& r, RobotDescription& robot) {
  if (!r.has("legs") || !r.node()["legs"].IsSequence() || r.node()["legs"].size() == 0) {
    r.fail("legs", "must be a list of legs, each {name, group, hip, knee, [ankle], foot}");
  }
  const std::size_t n = r.node()["legs"].size();
  if (n > 8) r.fail("legs", fmt::format("{} legs: cpgmatch drives at most 8", n));
  std::set<std::string> names, used_joints;
  for (std::size_t i = 0; i < n; ++i) {
    const YamlReader l = element(r, i, "legs");
    if (!l.node().IsMap()) l.fail("", "must be a mapping {name, group, hip, knee, [ankle], foot}");
    l.reject_unknown_keys({"name", "group", "hip", "knee", "ankle", "foot"});
    LegDescription leg;
    leg.name = l.require_string("name");
    if (auto problem = name_problem(leg.name, 32)) l.fail("name", *problem);
    if (!names.insert(leg.name).second) l.fail("name", fmt::format("leg '{}' is named twice", leg.name));
    leg.group = l.require_string("group");
    if (auto problem = name_problem(leg.group, 32)) l.fail("group", *problem);
    const JointDescription& hip = require_joint(l, "hip", robot);
    const JointDescription& knee = require_joint(l, "knee", robot);
    require_moving(l, "hip", hip);
    require_moving(l, "knee", knee);
    leg.hip_joint = hip.name;
    leg.knee_joint = knee.name;
    if (knee.parent_link != hip.child_link) {
      l.fail("knee", fmt::format("joint '{}' hangs from link '{}', not from '{}' (the link after the hip '{}')", knee.name,
                                 knee.parent_link, hip.child_link, hip.name));
    }
    std::string last_link = knee.child_link;
    if (l.has("ankle")) {
      const JointDescription& ankle = require_joint(l, "ankle", robot);
      require_moving(l, "ankle", ankle);
      if (ankle.parent_link != knee.child_link) {
        l.fail("ankle", fmt::format("joint '{}' hangs from link '{}', not from '{}' (the link after the knee '{}')",
                                    ankle.name, ankle.parent_link, knee.child_link, knee.name));
      }
      leg.ankle_joint = ankle.name;
      last_link = ankle.child_link;
    }
    for (const std::string* j : {&leg.hip_joint, &leg.knee_joint, &leg.ankle_joint}) {
      if (!j->empty() && !used_joints.insert(*j).second) l.fail("", fmt::format("joint '{}' belongs to two legs", *j));
    }
    leg.foot_link = l.require_string("foot");
    const LinkDescription* foot = robot.find_link(leg.foot_link);
    if (foot == nullptr) l.fail("foot", fmt::format("link '{}' is not in {}", escape_for_message(leg.foot_link), robot.urdf_source));
    if (leg.foot_link != last_link) {
      l.fail("foot", fmt::format("link '{}' is not the leg's last link '{}' (after joint '{}')", leg.foot_link, last_link,
                                 leg.ankle_joint.empty() ? leg.knee_joint : leg.ankle_joint));
    }
    const bool has_contact_shape = std::any_of(foot->collisions.begin(), foot->collisions.end(), [](const CollisionShape& s) {
      return s.kind == CollisionShape::Kind::kSphere;
    });
    if (!has_contact_shape) {
      l.fail("foot", fmt::format("link '{}' ({}) has no <collision> sphere: a foot touches the ground with one", foot->name,
                                 foot->where));
    }
    if (std::find(robot.groups.begin(), robot.groups.end(), leg.group) == robot.groups.end()) robot.groups.push_back(leg.group);
    robot.legs.push_back(std::move(leg));
  }
  // Every hip hangs from the trunk.
  for (const LegDescription& leg : robot.legs) {
    const JointDescription& hip = robot.joint(leg.hip_joint);
    if (hip.parent_link != robot.root_link) {
      r.fail("legs", fmt::format("leg {}: its hip '{}' hangs from '{}', not from the trunk (the URDF's root link '{}')",
                                 leg.name, hip.name, hip.parent_link, robot.root_link));
    }
  }
}

void parse_gaits(const YamlReader& r, RobotDescription& robot) {
  if (!r.has("gaits")) r.fail("gaits", "is required: name -> phase offsets (cycles), one per leg");
  const YamlReader g = r.child("gaits");
  g.check_keys();
  for (const auto& entry : g.node()) {
    const std::string name = entry.first.as<std::string>();
    const YAML::Node& seq = entry.second;
    if (!seq.IsSequence() || seq.size() != robot.legs.size()) {
      g.fail(name, fmt::format("must list {} phase offsets (cycles), one per leg in the order of 'legs'", robot.legs.size()));
    }
    GaitPreset gait;
    gait.name = name;
    for (std::size_t i = 0; i < seq.size(); ++i) {
      double v = 0.0;
      try {
        v = seq[i].as<double>();
      } catch (const YAML::Exception&) {
        g.fail(name, fmt::format("offset {} is not a number", i));
      }
      if (!(v >= 0.0 && v < 1.0)) g.fail(name, fmt::format("offset {} = {} must be in [0, 1) cycles", i, v));
      gait.phase_offsets.push_back(v);
    }
    robot.gaits.push_back(std::move(gait));
  }
  if (robot.gaits.empty()) r.fail("gaits", "must name at least one gait");
  if (r.has("default_gait")) {
    const std::string name = r.require_string("default_gait");
    auto it = std::find_if(robot.gaits.begin(), robot.gaits.end(), [&](const GaitPreset& p) { return p.name == name; });
    if (it == robot.gaits.end()) r.fail("default_gait", fmt::format("'{}' is not one of the robot's gaits", escape_for_message(name)));
    std::rotate(robot.gaits.begin(), it, it + 1);
  }
}

void parse_search_space(const YamlReader& r, RobotDescription& robot) {
  if (!r.has("search_space")) r.fail("search_space", "is required: the CPG parameters a study tunes, name -> {low, high, unit}");
  const YamlReader s = r.child("search_space");
  s.check_keys();
  for (const auto& entry : s.node()) {
    const std::string name = entry.first.as<std::string>();
    const YamlReader p = s.child(name);
    p.reject_unknown_keys({"low", "high", "unit"});
    const ParameterInfo* info = nullptr;
    try {
      info = &parameter_info(name);
    } catch (const InputError& e) {
      s.fail(name, fmt::format("no gait uses it: {}", e.what()));
    }
    SearchParameter sp;
    sp.name = name;
    sp.low = p.require_double("low");
    sp.high = p.require_double("high");
    sp.unit = p.get_string("unit", std::string(info->unit));
    if (!(sp.low < sp.high)) p.fail("low", "must be below high");
    if (sp.low < info->low || sp.high > info->high) {
      p.fail("low", fmt::format("[{}, {}] leaves the parameter's valid range [{}, {}] {}", sp.low, sp.high, info->low,
                                info->high, info->unit));
    }
    robot.search_space.push_back(sp);
  }
  if (robot.search_space.empty()) r.fail("search_space", "must name at least one parameter");
}

void parse_presets(const YamlReader& r, RobotDescription& robot) {
  if (!r.has("presets")) return;
  const YamlReader p = r.child("presets");
  p.check_keys();
  for (const auto& entry : p.node()) {
    const std::string name = entry.first.as<std::string>();
    CpgParameters params;
    std::map<std::string, double> values;
    p.child(name).for_each_number([&](const std::string& key, double value, const std::string& origin) {
      set_parameter(params, key, value, origin);
      values[key] = value;
    });
    robot.presets[name] = values;
  }
}

// A value `cpgmatch robot init` marked for the user and the user has not given yet: "FILL_IN" or "FILL_IN: ...".
void refuse_todo(const YAML::Node& node, const std::string& source, const std::string& path) {
  if (node.IsScalar()) {
    const std::string v = node.Scalar();
    if (v == "FILL_IN" || v.rfind("FILL_IN:", 0) == 0) {
      throw InputError(fmt::format("{}:{}: field '{}' is still FILL_IN: give its value (docs/your-robot.md)", source,
                                   node.Mark().line + 1, path));
    }
  } else if (node.IsMap()) {
    for (const auto& entry : node) {
      const std::string key = entry.first.IsScalar() ? entry.first.Scalar() : "?";
      if (key == "source" || key == "summary") continue;  // prose, not values
      refuse_todo(entry.second, source, path.empty() ? key : path + "." + key);
    }
  } else if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i) refuse_todo(node[i], source, fmt::format("{}[{}]", path, i));
  }
}

}  // namespace

double physical_value(const YamlReader& r, const std::string& key, double fallback) {
  if (!r.has(key)) return fallback;
  if (r.node()[key].IsMap()) {
    const YamlReader entry = r.child(key);
    entry.reject_unknown_keys({"value", "source", "unit"});
    const double v = entry.require_double("value");
    if (!std::isfinite(v)) entry.fail("value", "must be a finite number");
    return v;
  }
  return r.get_double(key, fallback);
}

double positive_value(const YamlReader& r, const std::string& key, double fallback) {
  const double v = physical_value(r, key, fallback);
  if (!(v > 0.0)) r.fail(key, "must be > 0");
  return v;
}

double non_negative_value(const YamlReader& r, const std::string& key, double fallback) {
  const double v = physical_value(r, key, fallback);
  if (!(v >= 0.0)) r.fail(key, "must be >= 0");
  return v;
}

ContactDescription parse_contact(const YamlReader& c, ContactDescription d) {
  c.reject_unknown_keys({"friction", "stiffness_n_per_m", "damping_n_s_per_m"});
  d.friction = positive_value(c, "friction", d.friction);
  d.stiffness_n_per_m = positive_value(c, "stiffness_n_per_m", d.stiffness_n_per_m);
  d.damping_n_s_per_m = positive_value(c, "damping_n_s_per_m", d.damping_n_s_per_m);
  return d;
}

FootSensorDescription parse_foot_sensor(const YamlReader& f, FootSensorDescription d) {
  f.reject_unknown_keys({"sensitivity", "time_constant_s"});
  d.sensitivity = positive_value(f, "sensitivity", d.sensitivity);
  d.time_constant_s = non_negative_value(f, "time_constant_s", d.time_constant_s);
  return d;
}

void parse_simulation(const YamlReader& s, double& physics_rate_hz, double& gravity_m_s2) {
  s.reject_unknown_keys({"physics_rate_hz", "gravity_m_s2"});
  physics_rate_hz = positive_value(s, "physics_rate_hz", physics_rate_hz);
  gravity_m_s2 = positive_value(s, "gravity_m_s2", gravity_m_s2);
}

fs::path shipped_robots_dir() {
  if (const char* env = std::getenv("CPGMATCH_CONFIG_DIR"); env && *env) return fs::path(env) / "robots";
  return fs::path(CPGMATCH_CONFIG_DIR) / "robots";
}

std::vector<std::string> shipped_robot_names() {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(shipped_robots_dir(), ec)) {
    if (entry.is_directory() && fs::is_regular_file(entry.path() / "robot.yaml")) names.push_back(entry.path().filename());
  }
  std::sort(names.begin(), names.end());
  return names;
}

bool names_shipped_robot(const std::string& name_or_path) {
  return name_or_path.find('/') == std::string::npos && name_or_path.find('.') == std::string::npos;
}

RobotDescription load_robot(const std::string& name_or_path) { return detail::load_robot_at_depth(name_or_path, 0); }

RobotDescription detail::load_robot_at_depth(const std::string& name_or_path, int depth) {
  fs::path yaml_path(name_or_path);
  if (names_shipped_robot(name_or_path) && !fs::exists(yaml_path)) {
    yaml_path = shipped_robots_dir() / name_or_path / "robot.yaml";
    if (!fs::exists(yaml_path)) {
      std::string known;
      for (const auto& n : shipped_robot_names()) known += (known.empty() ? "" : ", ") + n;
      throw InputError(fmt::format("robot '{}': no shipped robot of that name (shipped: {}) and no such folder",
                                   escape_for_message(name_or_path), known));
    }
  } else if (fs::is_directory(yaml_path)) {
    yaml_path /= "robot.yaml";
  }
  const std::string yaml_text = read_text_file(yaml_path.string(), "robot", kMaxYamlBytes);
  // The URDF's file name comes from the YAML; read it first to find it.
  const YamlReader reader = YamlReader::from_string(yaml_text, yaml_path.string());
  if (is_robot_overlay(reader)) return load_robot_overlay(reader, yaml_path, depth);
  const std::string urdf_name = reader.require_string("urdf");
  if (urdf_name.find("..") != std::string::npos || fs::path(urdf_name).is_absolute()) {
    reader.fail("urdf", "must name a file in the robot's folder (no absolute path, no '..')");
  }
  const fs::path urdf_path = yaml_path.parent_path() / urdf_name;
  const std::string urdf_text = read_text_file(urdf_path.string(), reader.where("urdf"), kMaxYamlBytes);
  return parse_robot(yaml_text, yaml_path.string(), urdf_text, urdf_path.string());
}

namespace {

// `links:` sets a URDF link's mass without editing the URDF (a battery, a payload, a calibrated trunk, a
// scenario's overlay). The change is spread like the link's own mass: its centre of mass stays where the URDF
// puts it and its inertia scales with the mass.
void apply_link_masses(const YamlReader& links, RobotDescription& robot) {
  links.check_keys();
  for (const auto& entry : links.node()) {
    const std::string name = entry.first.as<std::string>();
    const YamlReader l = links.child(name);
    l.reject_unknown_keys({"mass_kg"});
    const auto link = std::find_if(robot.links.begin(), robot.links.end(), [&](const LinkDescription& k) { return k.name == name; });
    if (link == robot.links.end()) links.fail(name, fmt::format("is not a link of {}", robot.urdf_source));
    const double mass_kg = required_positive(l, "mass_kg");
    for (double& inertia : link->inertia_kg_m2) inertia *= mass_kg / link->mass_kg;
    link->mass_kg = mass_kg;
  }
}

}  // namespace

RobotDescription parse_robot(const std::string& yaml_text, const std::string& yaml_source, const std::string& urdf_text,
                             const std::string& urdf_source) {
  const YamlReader r = YamlReader::from_string(yaml_text, yaml_source);
  r.reject_unknown_keys({"name", "summary", "urdf", "planar", "legs", "motors", "drives", "parallel_springs", "contact",
                         "foot_sensor", "simulation", "gaits", "default_gait", "presets", "search_space", "links"});
  refuse_todo(r.node(), yaml_source, "");
  UrdfModel urdf = parse_urdf(urdf_text, urdf_source);
  RobotDescription robot;
  robot.yaml_source = yaml_source;
  robot.urdf_source = urdf_source;
  robot.yaml_text = yaml_text;
  robot.urdf_text = urdf_text;
  robot.name = r.require_string("name");
  if (auto problem = name_problem(robot.name, 64)) r.fail("name", *problem);
  robot.summary = r.get_string("summary", "");
  robot.root_link = urdf.root_link;
  robot.links = std::move(urdf.links);
  robot.joints = std::move(urdf.joints);
  if (r.has("links")) apply_link_masses(r.child("links"), robot);
  robot.planar = r.get_bool("planar", true);

  parse_legs(r, robot);

  if (r.has("motors")) {
    const YamlReader m = r.child("motors");
    m.check_keys();
    for (const auto& entry : m.node()) {
      const std::string name = entry.first.as<std::string>();
      robot.motors[name] = parse_motor(m.child(name), name);
    }
  }
  if (!r.has("drives")) r.fail("drives", "is required: how each leg's hip and knee (and ankle) are driven");
  const YamlReader drives = r.child("drives");
  drives.reject_unknown_keys({"hip", "knee", "ankle"});
  for (const std::string role : {"hip", "knee"}) {
    if (!drives.has(role)) drives.fail(role, "is required");
  }
  const bool any_ankle = std::any_of(robot.legs.begin(), robot.legs.end(), [](const LegDescription& l) { return !l.ankle_joint.empty(); });
  for (const std::string role : {"hip", "knee", "ankle"}) {
    if (!drives.has(role)) continue;
    if (role == "ankle" && !any_ankle) drives.fail(role, "no leg has an ankle");
    robot.drives[role] = parse_drive(drives.child(role), robot.motors);
  }
  if (any_ankle && !robot.drives.count("ankle")) robot.drives["ankle"] = DriveDescription{};  // passive
  if (robot.drives.at("hip").kind == DriveDescription::Kind::kPassive) drives.fail("hip", "a hip must be driven (position_pd or series_elastic)");
  if (robot.drives.at("knee").kind == DriveDescription::Kind::kPassive) drives.fail("knee", "a knee must be driven (position_pd or series_elastic)");

  if (r.has("parallel_springs")) {
    if (!r.node()["parallel_springs"].IsSequence()) r.fail("parallel_springs", "must be a list");
    for (std::size_t i = 0; i < r.node()["parallel_springs"].size(); ++i) {
      const YamlReader s = element(r, i, "parallel_springs");
      s.reject_unknown_keys({"name", "from", "to", "stiffness_nm_per_rad", "damping_nm_s_per_rad"});
      ParallelSpringDescription p;
      p.name = s.require_string("name");
      p.from_role = s.require_string("from");
      p.to_role = s.require_string("to");
      for (const auto* role : {&p.from_role, &p.to_role}) {
        if (*role != "hip" && *role != "knee" && *role != "ankle") {
          s.fail(role == &p.from_role ? "from" : "to", "must be hip, knee or ankle (the link after that joint)");
        }
        if (*role == "ankle" && !any_ankle) s.fail(role == &p.from_role ? "from" : "to", "no leg has an ankle");
      }
      if (p.from_role == p.to_role) s.fail("to", "must differ from 'from'");
      p.spring.stiffness_nm_per_rad = required_positive(s, "stiffness_nm_per_rad");
      p.spring.damping_nm_s_per_rad = non_negative_value(s, "damping_nm_s_per_rad", 0.0);
      robot.parallel_springs.push_back(p);
    }
  }
  if (r.has("contact")) robot.contact = parse_contact(r.child("contact"), robot.contact);
  if (r.has("foot_sensor")) robot.foot_sensor = parse_foot_sensor(r.child("foot_sensor"), robot.foot_sensor);
  if (r.has("simulation")) parse_simulation(r.child("simulation"), robot.physics_rate_hz, robot.gravity_m_s2);
  parse_gaits(r, robot);
  parse_presets(r, robot);
  parse_search_space(r, robot);
  return robot;
}

}  // namespace cpgmatch
