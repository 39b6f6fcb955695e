#include "cpgmatch/calibration/calibrated_robot.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "cpgmatch/calibration/calibrated_model.hpp"
#include "cpgmatch/calibration/robot_values.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/sim/planar_leg_model.hpp"

namespace cpgmatch::calibration {
namespace {

namespace fs = std::filesystem;

// A text edit: replace [begin, end) by `text`. Edits are applied from the last to the first, so that the
// offsets of the others (taken on the original text) stay right.
struct Edit {
  std::size_t begin = 0, end = 0;
  std::string text;
};

std::string apply(std::string text, std::vector<Edit> edits) {
  std::sort(edits.begin(), edits.end(), [](const Edit& a, const Edit& b) { return a.begin > b.begin; });
  for (const Edit& e : edits) text.replace(e.begin, e.end - e.begin, e.text);
  return text;
}

// A double in its shortest form that reads back as the same double, with a decimal point (YAML then reads a
// float, as the hand-written entries are).
std::string exact(double v) {
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

// One past the end of the YAML entry starting at `begin`: a flow collection ({...} or [...], quotes
// respected) or a plain scalar (up to a flow indicator, a comment or the line's end).
std::size_t end_of_entry(const std::string& text, std::size_t begin, const std::string& what) {
  if (text[begin] == '{' || text[begin] == '[') {
    int depth = 0;
    char quote = 0;
    for (std::size_t i = begin; i < text.size(); ++i) {
      const char c = text[i];
      if (quote != 0) {
        if (quote == '"' && c == '\\') {
          ++i;
        } else if (c == quote) {
          quote = 0;  // a single-quoted '' reopens at once, which is the same thing for finding the end
        }
      } else if (c == '"' || c == '\'') {
        quote = c;
      } else if (c == '{' || c == '[') {
        ++depth;
      } else if ((c == '}' || c == ']') && --depth == 0) {
        return i + 1;
      }
    }
    throw InputError(fmt::format("{}: its flow entry is not closed", what));
  }
  std::size_t end = begin;
  while (end < text.size() && std::string(",}]\n#").find(text[end]) == std::string::npos) ++end;
  while (end > begin && std::isspace(static_cast<unsigned char>(text[end - 1]))) --end;
  return end;
}

YAML::Node entry_at(const YAML::Node& root, const std::vector<std::string>& path) {
  YAML::Node node;
  node.reset(root);
  for (const std::string& key : path) {
    YAML::Node next;
    next.reset(node.IsSequence() ? node[std::stoul(key)] : node[key]);
    node.reset(next);
  }
  return node;
}

// The edit that puts a fitted value into robot.yaml in place of its entry.
Edit yaml_edit(const std::string& text, const YAML::Node& root, const RobotValueSite& site, const FittedValue& v,
               const CalibrationResult& result) {
  const YAML::Node entry = entry_at(root, site.yaml_path);
  const auto begin = static_cast<std::size_t>(entry.Mark().pos);
  const std::string what = fmt::format("robot.yaml:{}: {} ({})", entry.Mark().line + 1, site.label, v.name);
  if (entry.IsMap() && text[begin] != '{') {
    throw InputError(fmt::format("{}: calibration rewrites an entry written on one line as '{{value: ..., source: ...}}' "
                                 "or a number, not a block map",
                                 what));
  }
  std::string previous_source, unit;
  if (entry.IsMap() && entry["source"]) previous_source = entry["source"].as<std::string>();
  if (entry.IsMap() && entry["unit"]) unit = fmt::format(", unit: \"{}\"", entry["unit"].as<std::string>());
  std::string note = calibrated_source(v, result, previous_source);
  std::replace(note.begin(), note.end(), '\\', '/');  // a double-quoted YAML string would read it as an escape
  // The exact estimate, not 6 digits: the written robot's model is then the fitted one to the bit.
  return {begin, end_of_entry(text, begin, what), fmt::format("{{value: {}, source: \"{}\"{}}}", exact(v.estimate), note, unit)};
}

// [begin, end) of the value of attribute `name` in the tag text[tag_begin, tag_end); npos when absent.
std::pair<std::size_t, std::size_t> attribute(const std::string& text, std::size_t tag_begin, std::size_t tag_end,
                                              const std::string& name) {
  for (std::size_t at = text.find(name, tag_begin); at < tag_end; at = text.find(name, at + 1)) {
    if (!std::isspace(static_cast<unsigned char>(text[at - 1]))) continue;
    std::size_t i = at + name.size();
    while (i < tag_end && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i >= tag_end || text[i] != '=') continue;
    ++i;
    while (i < tag_end && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i >= tag_end || (text[i] != '"' && text[i] != '\'')) continue;
    const std::size_t close = text.find(text[i], i + 1);
    if (close < tag_end) return {i + 1, close};
  }
  return {std::string::npos, std::string::npos};
}

// The start of the first tag `<name` (followed by a space or '/', so that <inertia is not <inertial) in
// [from, to); npos when none.
std::size_t tag(const std::string& text, const std::string& name, std::size_t from, std::size_t to) {
  for (std::size_t at = text.find("<" + name, from); at < to; at = text.find("<" + name, at + 1)) {
    const char next = text[at + 1 + name.size()];
    if (std::isspace(static_cast<unsigned char>(next)) || next == '/' || next == '>') return at;
  }
  return std::string::npos;
}

// The URDF with the root link's mass set to the estimate and its inertia tensor scaled by the same ratio.
// Textual: one attribute each, everything else of the file as written; the result is parsed again below.
std::string urdf_with_trunk_mass(const std::string& urdf, const RobotDescription& robot, const FittedValue& mass,
                                 const CalibrationResult& result) {
  const std::string where = fmt::format("{} link '{}'", robot.urdf_source, robot.root_link);
  std::size_t link = std::string::npos;
  for (std::size_t at = tag(urdf, "link", 0, urdf.size()); at != std::string::npos;
       at = tag(urdf, "link", at + 1, urdf.size())) {
    const auto [b, e] = attribute(urdf, at, urdf.find('>', at), "name");
    if (b != std::string::npos && urdf.compare(b, e - b, robot.root_link) == 0) {
      link = at;
      break;
    }
  }
  const std::size_t link_end = link == std::string::npos ? link : urdf.find("</link>", link);
  const std::size_t inertial = link_end == std::string::npos ? link_end : tag(urdf, "inertial", link, link_end);
  const std::size_t mass_tag = inertial == std::string::npos ? inertial : tag(urdf, "mass", inertial, link_end);
  const std::size_t inertia_tag = inertial == std::string::npos ? inertial : tag(urdf, "inertia", inertial, link_end);
  if (mass_tag == std::string::npos || inertia_tag == std::string::npos) {
    throw InputError(fmt::format("{}: no <inertial> with <mass> and <inertia> to rewrite", where));
  }
  const double old_mass = robot.link(robot.root_link).mass_kg;
  const double ratio = mass.estimate / old_mass;
  std::vector<Edit> edits;
  const auto [mb, me] = attribute(urdf, mass_tag, urdf.find('>', mass_tag), "value");
  if (mb == std::string::npos) throw InputError(fmt::format("{}: <mass> has no value attribute", where));
  edits.push_back({mb, me, exact(mass.estimate)});
  for (const char* component : {"ixx", "ixy", "ixz", "iyy", "iyz", "izz"}) {
    const auto [b, e] = attribute(urdf, inertia_tag, urdf.find('>', inertia_tag), component);
    if (b == std::string::npos) continue;  // urdfdom reads an absent component as 0, which scales to 0
    edits.push_back({b, e, exact(std::stod(urdf.substr(b, e - b)) * ratio)});
  }
  // Why the inertia is scaled: a fitted mass says the trunk weighs more (a battery, a payload), not where;
  // scaling the tensor keeps its radii of gyration, the body's shape. Placed before <inertial>, indented alike.
  const std::size_t line_start = urdf.rfind('\n', inertial) + 1;
  const std::string indent = urdf.substr(line_start, inertial - line_start);
  std::string note = fmt::format(
      "cpgmatch calibrate, the trunk's mass: {}. The inertia tensor is scaled by the same ratio {:.6g}: the fit gives "
      "the mass, not where it sits, so the trunk keeps its shape (radii of gyration).",
      calibrated_source(mass, result, ""), ratio);
  for (std::size_t d = note.find("--"); d != std::string::npos; d = note.find("--")) note.replace(d, 2, "- ");  // not in XML comments
  const std::string comment = "<!-- " + note + " -->\n" + indent;
  edits.push_back({inertial, inertial, comment});
  return apply(urdf, edits);
}

std::string urdf_file_of(const RobotDescription& robot) {
  const YAML::Node root = YAML::Load(robot.yaml_text);
  const std::string file = root["urdf"] ? root["urdf"].as<std::string>() : std::string("robot.urdf");
  const fs::path p(file);
  if (p.is_absolute() || std::any_of(p.begin(), p.end(), [](const fs::path& part) { return part == ".."; })) {
    throw InputError(fmt::format("{}: urdf '{}': a calibrated robot's URDF is written inside its folder; give a "
                                 "name relative to robot.yaml, without '..'",
                                 robot.yaml_source, file));
  }
  return file;
}

bool same(double a, double b) { return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(b)); }

}  // namespace

CalibratedRobot calibrated_robot(const RobotDescription& robot, const std::string& robot_source,
                                 const CalibrationResult& result, const std::vector<std::string>& trace_sources) {
  CalibratedRobot out;
  out.urdf_file = urdf_file_of(robot);
  out.urdf = robot.urdf_text;
  const YAML::Node root = YAML::Load(robot.yaml_text);
  std::vector<Edit> edits;
  for (const FittedValue& v : result.values) {
    const RobotValueSite site = robot_value_site(find_model_value(v.name), robot);
    if (site.file == RobotValueSite::File::kUrdfTrunkMass) {
      out.urdf = urdf_with_trunk_mass(robot.urdf_text, robot, v, result);
    } else {
      edits.push_back(yaml_edit(robot.yaml_text, root, site, v, result));
    }
  }
  std::string header = calibration_header(robot_source, result, trace_sources);
  if (out.urdf != robot.urdf_text) {
    header += fmt::format("# trunk.mass_kg is the URDF's: {}, link '{}' (its <mass>, the inertia scaled alike).\n",
                          out.urdf_file, robot.root_link);
  }
  out.robot_yaml = header + apply(robot.yaml_text, edits);

  // What is written must load and hold the fit: parsed as the loader parses a folder, its model built.
  const RobotDescription back = parse_robot(out.robot_yaml, "calibrated robot.yaml", out.urdf, "calibrated " + out.urdf_file);
  sim::PlanarLegModel model = sim::planar_leg_model(back);
  for (const FittedValue& v : result.values) {
    if (!same(find_model_value(v.name).get(model), v.estimate)) {
      throw std::logic_error(fmt::format("calibrated robot: {} reads back as {}, not the estimate {}", v.name,
                                         find_model_value(v.name).get(model), v.estimate));
    }
  }
  const LinkDescription& before = robot.link(robot.root_link);
  const LinkDescription& after = back.link(back.root_link);
  for (std::size_t i = 0; i < before.inertia_kg_m2.size(); ++i) {
    if (!same(after.inertia_kg_m2[i], before.inertia_kg_m2[i] * after.mass_kg / before.mass_kg)) {
      throw std::logic_error("calibrated robot: the trunk's inertia is not scaled with its mass");
    }
  }
  return out;
}

RobotDescription write_calibrated_robot(const std::string& dir, const CalibratedRobot& files) {
  const fs::path folder(dir);
  std::error_code ec;
  fs::create_directories(folder / fs::path(files.urdf_file).parent_path(), ec);
  if (ec) throw InputError(fmt::format("--out {}: cannot make the folder: {}", dir, ec.message()));
  for (const auto& [name, text] : {std::pair{std::string("robot.yaml"), &files.robot_yaml}, std::pair{files.urdf_file, &files.urdf}}) {
    std::ofstream out(folder / name);
    if (!(out << *text) || !(out.flush())) throw InputError(fmt::format("--out {}: cannot write {}", dir, name));
  }
  return load_robot(dir);
}

}  // namespace cpgmatch::calibration
