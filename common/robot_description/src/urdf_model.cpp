// The URDF half of a robot description: parsed by urdfdom, located by tinyxml2 (line numbers only).
#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <set>

#include <console_bridge/console.h>
#include <fmt/format.h>
#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot_description_loader.hpp"

namespace cpgmatch {
namespace {

// The largest URDF text cpgmatch reads. A legged robot's URDF without meshes is a few tens of kB; this
// bounds what a study spec can make every worker parse.
constexpr std::size_t kMaxUrdfBytes = std::size_t{1} << 20;

// urdfdom reports why a text does not parse through console_bridge; this collects those messages for
// the InputError instead of letting them go to stderr.
class CollectingHandler final : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR) messages.push_back(text);
  }
  std::vector<std::string> messages;
};

// urdfdom's console_bridge handler is process-wide: one parse at a time.
std::mutex& parse_mutex() {
  static std::mutex m;
  return m;
}

// Line numbers of <link name=...> and <joint name=...> elements (urdfdom keeps none).
struct UrdfLines {
  std::map<std::string, int> links, joints;
};

UrdfLines locate_elements(const std::string& text) {
  UrdfLines lines;
  tinyxml2::XMLDocument doc;
  if (doc.Parse(text.c_str(), text.size()) != tinyxml2::XML_SUCCESS) return lines;
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (robot == nullptr) return lines;
  for (auto* e = robot->FirstChildElement(); e != nullptr; e = e->NextSiblingElement()) {
    const char* name = e->Attribute("name");
    if (name == nullptr) continue;
    if (std::string(e->Name()) == "link") lines.links.emplace(name, e->GetLineNum());
    if (std::string(e->Name()) == "joint") lines.joints.emplace(name, e->GetLineNum());
  }
  return lines;
}

// The line where the XML itself breaks, if it does.
std::optional<std::string> xml_problem(const std::string& text, const std::string& source) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(text.c_str(), text.size()) == tinyxml2::XML_SUCCESS) return std::nullopt;
  return fmt::format("{}:{}: not well-formed XML: {}", source, doc.ErrorLineNum(), doc.ErrorStr());
}

Vec3 vec(const urdf::Vector3& v) { return {v.x, v.y, v.z}; }

Origin origin_of(const urdf::Pose& p) {
  Origin o;
  o.xyz = vec(p.position);
  p.rotation.getRPY(o.rpy.x, o.rpy.y, o.rpy.z);
  return o;
}

bool finite(const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

JointType joint_type(int urdf_type) {
  switch (urdf_type) {
    case urdf::Joint::REVOLUTE: return JointType::kRevolute;
    case urdf::Joint::CONTINUOUS: return JointType::kContinuous;
    case urdf::Joint::PRISMATIC: return JointType::kPrismatic;
    case urdf::Joint::FIXED: return JointType::kFixed;
    default: return JointType::kOther;
  }
}

std::optional<CollisionShape> shape_of(const urdf::Collision& c) {
  if (!c.geometry) return std::nullopt;
  CollisionShape s;
  s.origin = origin_of(c.origin);
  switch (c.geometry->type) {
    case urdf::Geometry::SPHERE:
      s.kind = CollisionShape::Kind::kSphere;
      s.radius_m = static_cast<const urdf::Sphere&>(*c.geometry).radius;
      return s;
    case urdf::Geometry::BOX:
      s.kind = CollisionShape::Kind::kBox;
      s.box_size_m = vec(static_cast<const urdf::Box&>(*c.geometry).dim);
      return s;
    case urdf::Geometry::CYLINDER: {
      const auto& cyl = static_cast<const urdf::Cylinder&>(*c.geometry);
      s.kind = CollisionShape::Kind::kCylinder;
      s.radius_m = cyl.radius;
      s.length_m = cyl.length;
      return s;
    }
    default:
      return std::nullopt;  // meshes: cpgmatch collides spheres, boxes and cylinders only
  }
}

}  // namespace

UrdfModel parse_urdf(const std::string& text, const std::string& source) {
  if (text.size() > kMaxUrdfBytes) {
    throw InputError(fmt::format("{}: a URDF of {} bytes is over the limit of {} bytes", source, text.size(), kMaxUrdfBytes));
  }
  if (auto problem = xml_problem(text, source)) throw InputError(*problem);
  const UrdfLines lines = locate_elements(text);
  auto link_where = [&](const std::string& name) {
    auto it = lines.links.find(name);
    return it == lines.links.end() ? source : fmt::format("{}:{}", source, it->second);
  };
  auto joint_where = [&](const std::string& name) {
    auto it = lines.joints.find(name);
    return it == lines.joints.end() ? source : fmt::format("{}:{}", source, it->second);
  };

  urdf::ModelInterfaceSharedPtr model;
  std::vector<std::string> messages;
  {
    std::lock_guard lock(parse_mutex());
    CollectingHandler handler;
    console_bridge::useOutputHandler(&handler);
    try {
      model = urdf::parseURDF(text);
    } catch (const std::exception& e) {
      handler.messages.push_back(e.what());
    }
    console_bridge::restorePreviousOutputHandler();
    messages = std::move(handler.messages);
  }
  if (!model) {
    std::string why = messages.empty() ? "urdfdom could not parse it" : messages.front();
    for (std::size_t i = 1; i < messages.size(); ++i) why += "; " + messages[i];
    throw InputError(fmt::format("{}: not a valid URDF: {}", source, why));
  }

  UrdfModel out;
  out.robot_name = model->getName();
  if (!model->getRoot()) throw InputError(fmt::format("{}: the URDF has no root link", source));
  out.root_link = model->getRoot()->name;

  // Links in document order, so that messages and listings follow the file.
  std::vector<std::pair<int, std::string>> link_order;
  for (const auto& [name, link] : model->links_) link_order.emplace_back(lines.links.count(name) ? lines.links.at(name) : 0, name);
  std::sort(link_order.begin(), link_order.end());
  for (const auto& [line, name] : link_order) {
    const urdf::LinkSharedPtr& link = model->links_.at(name);
    LinkDescription d;
    d.name = name;
    d.where = link_where(name);
    if (!link->inertial) throw InputError(fmt::format("{}: link '{}' has no <inertial> (mass and inertia)", d.where, name));
    const urdf::Inertial& in = *link->inertial;
    if (!(std::isfinite(in.mass) && in.mass > 0.0)) {
      throw InputError(fmt::format("{}: link '{}': mass must be > 0 kg (is {})", d.where, name, in.mass));
    }
    d.mass_kg = in.mass;
    d.inertial_origin = origin_of(in.origin);
    d.inertia_kg_m2 = {in.ixx, in.ixy, in.ixz, in.iyy, in.iyz, in.izz};
    for (double v : d.inertia_kg_m2) {
      if (!std::isfinite(v)) throw InputError(fmt::format("{}: link '{}': inertia is not finite", d.where, name));
    }
    // A physical inertia has positive principal moments that satisfy the triangle inequality; checked on
    // the diagonal, which is what a URDF of a legged robot's links gives (products near zero).
    const double ixx = in.ixx, iyy = in.iyy, izz = in.izz;
    if (!(ixx > 0.0 && iyy > 0.0 && izz > 0.0)) {
      throw InputError(fmt::format("{}: link '{}': ixx, iyy and izz must be > 0 kg m^2", d.where, name));
    }
    const double slack = 1e-9 * (ixx + iyy + izz);
    if (ixx + iyy + slack < izz || iyy + izz + slack < ixx || izz + ixx + slack < iyy) {
      throw InputError(fmt::format("{}: link '{}': inertia ({}, {}, {}) breaks the triangle inequality (no rigid body has it)",
                                   d.where, name, ixx, iyy, izz));
    }
    if (!finite(d.inertial_origin.xyz)) throw InputError(fmt::format("{}: link '{}': inertial origin is not finite", d.where, name));
    for (const auto& c : link->collision_array) {
      if (!c) continue;
      if (auto shape = shape_of(*c)) d.collisions.push_back(*shape);
    }
    if (link->collision_array.empty() && link->collision) {
      if (auto shape = shape_of(*link->collision)) d.collisions.push_back(*shape);
    }
    out.links.push_back(std::move(d));
  }

  std::vector<std::pair<int, std::string>> joint_order;
  for (const auto& [name, joint] : model->joints_) joint_order.emplace_back(lines.joints.count(name) ? lines.joints.at(name) : 0, name);
  std::sort(joint_order.begin(), joint_order.end());
  for (const auto& [line, name] : joint_order) {
    const urdf::JointSharedPtr& j = model->joints_.at(name);
    JointDescription d;
    d.name = name;
    d.where = joint_where(name);
    d.type = joint_type(j->type);
    d.parent_link = j->parent_link_name;
    d.child_link = j->child_link_name;
    d.origin = origin_of(j->parent_to_joint_origin_transform);
    d.axis = vec(j->axis);
    if (!finite(d.origin.xyz) || !finite(d.origin.rpy) || !finite(d.axis)) {
      throw InputError(fmt::format("{}: joint '{}': origin or axis is not finite", d.where, name));
    }
    if (j->limits) {
      d.limited = d.type == JointType::kRevolute || d.type == JointType::kPrismatic;
      d.lower = j->limits->lower;
      d.upper = j->limits->upper;
      d.effort_limit = j->limits->effort;
      d.velocity_limit = j->limits->velocity;
      if (d.limited && !(d.lower < d.upper)) {
        throw InputError(fmt::format("{}: joint '{}': limit lower {} must be below upper {}", d.where, name, d.lower, d.upper));
      }
    }
    out.joints.push_back(std::move(d));
  }
  return out;
}

const char* to_string(JointType type) {
  switch (type) {
    case JointType::kRevolute: return "revolute";
    case JointType::kContinuous: return "continuous";
    case JointType::kPrismatic: return "prismatic";
    case JointType::kFixed: return "fixed";
    case JointType::kOther: return "other";
  }
  return "other";
}

}  // namespace cpgmatch
