#include "cpgmatch/study/robot_file.hpp"

#include <algorithm>
#include <filesystem>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/study/model_file.hpp"
#include "cpgmatch/study/study_config.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch::study {

namespace {

// A text as a YAML double-quoted scalar (a JSON string is one); `what` names it when it is not UTF-8.
std::string quoted(const std::string& text, const YamlReader& r, const std::string& what) {
  try {
    return nlohmann::json(text).dump();
  } catch (const nlohmann::json::exception&) {
    r.fail("robot", fmt::format("{} is not UTF-8 text", what));
  }
}

}  // namespace

std::string with_robot_files(const std::string& study_yaml, const std::string& study_path) {
  const YamlReader r = YamlReader::from_string(study_yaml, study_path);
  for (const char* key : {kRobotYamlTextKey, kRobotUrdfTextKey}) {
    if (r.has(key)) r.fail(key, "is written by the submitting client; name the robot in 'robot' instead");
  }
  if (!r.has("robot") || !r.node()["robot"].IsScalar()) return study_yaml;  // a non-scalar: the parser says so
  const std::string name = r.node()["robot"].Scalar();
  namespace fs = std::filesystem;
  const fs::path path = fs::path(name).is_absolute() ? fs::path(name) : fs::path(study_path).parent_path() / name;
  // A plain name is a shipped robot, which the optimizer's own release has, unless a folder of that name is
  // beside the study file (as for `cpgmatch rollout --robot`: the user's own robot wins).
  std::error_code ignored;
  if (names_shipped_robot(name) && !fs::exists(path, ignored)) return study_yaml;
  if (r.node().Style() == YAML::EmitterStyle::Flow) {
    r.fail("robot", "a robot of your own needs the study written as a block mapping (one key per line)");
  }
  RobotDescription robot;
  try {
    robot = load_robot(path.string());  // bounded regular-file reads; checks the robot as the optimizer will
  } catch (const InputError& e) {
    r.fail("robot", fmt::format("{} (relative to the study file: {})", e.what(), path.string()));
  }
  const std::size_t total = study_yaml.size() + robot.yaml_text.size() + robot.urdf_text.size();
  if (total > kMaxStudyFileBytes) {
    r.fail("robot", fmt::format("the study file with its robot '{}' has {} bytes, more than a study may have ({})", name,
                                total, kMaxStudyFileBytes));
  }
  std::string out = study_yaml;
  if (!out.empty() && out.back() != '\n') out += '\n';
  // Appended, not re-emitted: the study's own lines keep their numbers for every later error.
  out += fmt::format("# the robot {} ({}), added by the submitting client\n{}: {}\n{}: {}\n", robot.name, name,
                     kRobotYamlTextKey, quoted(robot.yaml_text, r, robot.yaml_source), kRobotUrdfTextKey,
                     quoted(robot.urdf_text, r, robot.urdf_source));
  return out;
}

bo::SearchSpace robot_search_space(const RobotDescription& robot, const std::map<std::string, double>* preset) {
  std::vector<bo::Dimension> dims;
  for (const SearchParameter& p : robot.search_space) dims.push_back({p.name, p.low, p.high, false, p.unit});
  std::map<std::string, double> fixed;
  if (preset != nullptr) {
    for (const auto& [name, value] : *preset) {
      const bool searched = std::any_of(dims.begin(), dims.end(), [&](const bo::Dimension& d) { return d.name == name; });
      if (!searched) fixed[name] = value;
    }
  }
  return bo::SearchSpace(std::move(dims), std::move(fixed));
}

std::string with_named_files(const std::string& study_yaml, const std::string& study_path) {
  return with_robot_files(with_model_file(study_yaml, study_path), study_path);
}

}  // namespace cpgmatch::study
