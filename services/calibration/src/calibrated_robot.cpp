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
#include "text_edits.hpp"
#include "urdf_trunk_mass.hpp"
#include "yaml_entry.hpp"

namespace cpgmatch::calibration {
namespace {

namespace fs = std::filesystem;

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

// The edit that puts a fitted value into robot.yaml in place of its entry.
Edit yaml_edit(const std::string& text, const YAML::Node& root, const RobotValueSite& site, const FittedValue& v,
               const CalibrationResult& result) {
  const YAML::Node entry = yaml_entry(root, site.yaml_path);
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
  return {begin, end_of_entry(text, begin, what), fmt::format("{{value: {}, source: \"{}\"{}}}", exact_decimal(v.estimate), note, unit)};
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
  out.robot_yaml = header + apply_edits(robot.yaml_text, edits);

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
