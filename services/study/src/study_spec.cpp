#include "cpgmatch/study/study_spec.hpp"

#include <openssl/evp.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>

#include <fmt/format.h>

#include "cpgmatch/bo/optimizer.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/sim/planar_leg_model.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/study/model_file.hpp"
#include "cpgmatch/study/robot_file.hpp"
#include "cpgmatch/text.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch::study {

namespace {

// The sections of a spec besides the study's own keys, and the default file each is merged onto.
constexpr const char* kModel = "model";
constexpr const char* kSettings = "rollout_settings";
constexpr const char* kBaseParameters = "base_parameters";
constexpr const char* kStudy = "study";
// A study of a robot (robot_file.hpp): {"name", "robot_yaml", "urdf"}, the description's two texts as read. Such a
// spec has no `model` section: its model is the one its robot's description builds.
constexpr const char* kRobot = "robot";

}  // namespace

std::string sha256_hex(const std::string& text) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_Digest(text.data(), text.size(), digest, &length, EVP_sha256(), nullptr) != 1) {
    throw std::runtime_error("SHA-256 of a study spec failed (OpenSSL EVP_Digest)");
  }
  std::string hex;
  for (unsigned int i = 0; i < length; ++i) hex += fmt::format("{:02x}", digest[i]);
  return hex;
}

namespace {

nlohmann::json scalar_to_json(const YAML::Node& node) {
  const std::string& text = node.Scalar();
  if (node.Tag() == "!") return text;  // quoted: a string whatever it looks like
  if (text == "true" || text == "True" || text == "TRUE") return true;
  if (text == "false" || text == "False" || text == "FALSE") return false;
  if (text.empty() || text == "~" || text == "null" || text == "Null" || text == "NULL") return nullptr;
  char* end = nullptr;
  const long long integer = std::strtoll(text.c_str(), &end, 10);
  if (end == text.c_str() + text.size() && text.find_first_of(".eE") == std::string::npos) {
    return static_cast<std::int64_t>(integer);
  }
  const double number = std::strtod(text.c_str(), &end);
  if (end == text.c_str() + text.size() && std::isfinite(number)) return number;
  return text;
}

// Every number of a model, settings or parameter tree as a double: the loaders read doubles, and "20" and
// "20.0" must be the same experiment (and the same hash).
void numbers_to_double(nlohmann::json& j) {
  if (j.is_number()) {
    j = j.get<double>();
  } else if (j.is_structured()) {
    for (auto& item : j) numbers_to_double(item);
  }
}

std::string number_text(double v) {
  std::string text = fmt::format("{}", v);  // shortest text that reads back to the same double
  if (text.find_first_of(".eEn") == std::string::npos) text += ".0";  // stays a double when read back
  return text;
}

void emit(YAML::Emitter& out, const nlohmann::json& j) {
  if (j.is_object()) {
    out << YAML::BeginMap;
    for (const auto& [key, value] : j.items()) {
      out << YAML::Key << key << YAML::Value;
      emit(out, value);
    }
    out << YAML::EndMap;
  } else if (j.is_array()) {
    out << YAML::BeginSeq;
    for (const auto& item : j) emit(out, item);
    out << YAML::EndSeq;
  } else if (j.is_string()) {
    out << YAML::DoubleQuoted << j.get<std::string>();
  } else if (j.is_boolean()) {
    out << (j.get<bool>() ? "true" : "false");
  } else if (j.is_number_float()) {
    out << number_text(j.get<double>());
  } else if (j.is_number()) {
    out << j.dump();
  } else {
    out << YAML::Null;
  }
}

// A model entry with its provenance: {value: X, source: "..."}.
bool is_sourced_value(const nlohmann::json& j) { return j.is_object() && j.contains("value"); }

std::string known_keys(const nlohmann::json& j) {
  std::string out;
  for (const auto& [key, value] : j.items()) out += (out.empty() ? "" : ", ") + key;
  return out;
}

bool same_value(const nlohmann::json& a, const nlohmann::json& b) {
  if (a.is_number() && b.is_number()) return a.get<double>() == b.get<double>();
  return a == b;
}

// Replaces `leaf` by the override's scalar, which must be of the same kind (number, boolean, string).
void replace_value(nlohmann::json& leaf, const YAML::Node& value, const YamlReader& overrides, const std::string& key) {
  if (!value.IsScalar()) overrides.fail(key, "must be a single value");
  const nlohmann::json replacement = scalar_to_json(value);
  const bool same_kind = (leaf.is_number() && replacement.is_number()) ||
                         (leaf.is_boolean() && replacement.is_boolean()) ||
                         (leaf.is_string() && replacement.is_string());
  if (!same_kind) {
    overrides.fail(key, fmt::format("'{}' is not a {}", value.Scalar(),
                                    leaf.is_number() ? "number" : leaf.is_boolean() ? "boolean (true/false)" : "string"));
  }
  leaf = replacement;
}

// A model entry {value, source}: the new value, and a source that stays honest. A value equal to the
// default's keeps the default's source (the same experiment, the same hash); a changed one says "study
// override" unless the file gives its own source; a source alone, without a value, is refused.
void override_sourced(nlohmann::json& slot, const YAML::Node& value, const YamlReader& overrides, const std::string& key) {
  const nlohmann::json before = slot["value"];
  if (value.IsMap()) {
    const YamlReader entry = overrides.child(key);
    entry.reject_unknown_keys({"value", "source"});
    if (!entry.has("value")) entry.fail("source", "overrides only the source of a value; give its value too");
    replace_value(slot["value"], entry.node()["value"], entry, "value");
    if (entry.has("source")) {
      slot["source"] = entry.require_string("source");
      return;
    }
  } else {
    replace_value(slot["value"], value, overrides, key);
  }
  if (!same_value(before, slot["value"])) slot["source"] = "study override";
}

// Merges a study file's overrides (with their file:line) onto a default tree. Only keys the default has
// may be overridden, with a value of the same shape: a typo is an error, never a silently new key.
void merge_overrides(nlohmann::json& target, const YamlReader& overrides) {
  overrides.check_keys();
  for (const auto& entry : overrides.node()) {
    const std::string key = entry.first.Scalar();
    if (!target.contains(key)) {
      overrides.fail(key, fmt::format("no such key here (known: {})", known_keys(target)));
    }
    nlohmann::json& slot = target[key];
    const YAML::Node& value = entry.second;
    if (is_sourced_value(slot)) {
      override_sourced(slot, value, overrides, key);
    } else if (value.IsMap()) {
      if (!slot.is_object()) overrides.fail(key, "is a single value here, not a mapping");
      merge_overrides(slot, overrides.child(key));
    } else {
      if (slot.is_object()) overrides.fail(key, "is a mapping here, not a single value");
      replace_value(slot, value, overrides, key);
    }
  }
}

// The study's own keys as a tree. Numbers as doubles (budget 150 and 150.0 are one study); keys whose
// value is text stay the text as written (a study named 1.10, a robot 007).
nlohmann::json study_section(const YAML::Node& root) {
  // `model` is here as a file name only (model_file.hpp): the model's content is the spec's own section.
  static const std::set<std::string> kTextKeys = {"name",  "model",   "robot",          "terrain",    "acquisition",
                                                  "initial_design", "liar", "cost_transform", "explore_on"};
  nlohmann::json study = nlohmann::json::object();
  for (const auto& entry : root) {
    const std::string key = entry.first.Scalar();
    if ((key == "model" && !entry.second.IsScalar()) || key == "rollout_settings" || key == "base_parameters" ||
        key == kModelFileTextKey || key == kRobotYamlTextKey || key == kRobotUrdfTextKey) {
      continue;
    }
    // Enqueued gaits are trials of the study (stored with their values, phase "enqueued"), not its objective.
    if (key == "enqueue") continue;
    if (kTextKeys.count(key) > 0 && entry.second.IsScalar()) {
      study[key] = entry.second.Scalar();
    } else {
      nlohmann::json value = yaml_to_json(entry.second);
      numbers_to_double(value);
      study[key] = std::move(value);
    }
  }
  return study;
}

nlohmann::json parse_default_tree(const std::string& path) {
  const YamlReader r = YamlReader::from_string(read_text_file(path, path), path);
  nlohmann::json j = yaml_to_json(r.node());
  numbers_to_double(j);
  return j;
}

// A defaults file as a tree, parsed once per content: the service resolves every submitted study onto the
// same three files, and re-parsing them for each of 20 studies submitted at once held its event loop for
// 7 ms a study. Keyed by path and modification time, so an edited defaults file counts for new studies.
nlohmann::json default_tree(const std::string& path) {
  static std::mutex mutex;
  static std::map<std::string, std::pair<std::filesystem::file_time_type, nlohmann::json>> cache;
  std::error_code error;
  const auto modified = std::filesystem::last_write_time(path, error);
  if (error) return parse_default_tree(path);  // names the file in its error
  std::lock_guard<std::mutex> lock(mutex);
  const auto it = cache.find(path);
  if (it != cache.end() && it->second.first == modified) return it->second.second;
  nlohmann::json tree = parse_default_tree(path);
  cache[path] = {modified, tree};
  return tree;
}

YamlReader reader_of(const nlohmann::json& tree, const std::string& source_name) {
  return YamlReader::from_string(json_to_yaml(tree), source_name);
}

// The robot a study file names: from the texts its client sent (a robot of the user's own), else the shipped
// robot of that name from this release. Never a file the client names: only shipped names are looked up here.
std::optional<RobotDescription> study_robot(const YamlReader& r) {
  if (!r.has("robot")) return std::nullopt;
  const std::string name = r.require_string("robot");
  if (r.has(kRobotYamlTextKey) != r.has(kRobotUrdfTextKey)) {
    r.fail(r.has(kRobotYamlTextKey) ? kRobotYamlTextKey : kRobotUrdfTextKey,
           fmt::format("comes with {} and {} together (the submitting client writes both)", kRobotYamlTextKey,
                       kRobotUrdfTextKey));
  }
  if (r.has(kRobotYamlTextKey)) {
    // The robot's own file:line in every error, as a submit by file would show them.
    return parse_robot(r.require_string(kRobotYamlTextKey), name, r.require_string(kRobotUrdfTextKey),
                       fmt::format("the URDF of {}", name));
  }
  const std::vector<std::string> shipped = shipped_robot_names();
  if (!names_shipped_robot(name) || std::find(shipped.begin(), shipped.end(), name) == shipped.end()) {
    std::string known;
    for (const auto& n : shipped) known += (known.empty() ? "" : ", ") + n;
    r.fail("robot", fmt::format("'{}' is not a shipped robot (shipped: {}); a robot of your own is named by its "
                                "robot.yaml or folder, relative to the study file, whose content the submitting "
                                "client sends (`cpgmatch study submit`, `cpgmatch study run`)",
                                escape_for_message(name), known));
  }
  return load_robot((shipped_robots_dir() / name).string());
}

// A study's space is its robot's, the default preset fixed on what the robot does not search.
bo::SearchSpace robot_space(const RobotDescription& robot) {
  const auto preset = robot.presets.find("default");
  return robot_search_space(robot, preset != robot.presets.end() ? &preset->second : nullptr);
}

RobotDescription robot_of_tree(const nlohmann::json& section, const std::string& source_name) {
  for (const char* key : {"name", "robot_yaml", "urdf"}) {
    if (!section.contains(key) || !section[key].is_string()) {
      throw InputError(fmt::format("{}: study spec's robot has no '{}' text", source_name, key));
    }
  }
  const std::string name = section["name"].get<std::string>();
  RobotDescription robot = parse_robot(section["robot_yaml"].get<std::string>(), fmt::format("{} (robot {})", source_name, name),
                                       section["urdf"].get<std::string>(), fmt::format("{} (URDF of {})", source_name, name));
  if (robot.name != name) {
    throw InputError(fmt::format("{}: study spec's robot is named '{}' but its robot.yaml says '{}'", source_name, name, robot.name));
  }
  return robot;
}

}  // namespace

nlohmann::json yaml_to_json(const YAML::Node& node) {
  if (node.IsMap()) {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& entry : node) j[entry.first.Scalar()] = yaml_to_json(entry.second);
    return j;
  }
  if (node.IsSequence()) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& item : node) j.push_back(yaml_to_json(item));
    return j;
  }
  if (node.IsScalar()) return scalar_to_json(node);
  return nullptr;
}

std::string json_to_yaml(const nlohmann::json& tree) {
  YAML::Emitter out;
  emit(out, tree);
  return std::string(out.c_str()) + "\n";
}

std::string spec_key_hex(std::uint64_t key) { return fmt::format("{:016x}", key); }

SpecDefaults SpecDefaults::shipped() {
  return SpecDefaults{sim::default_model_path(), sim::default_rollout_settings_path(), sim::default_params_path()};
}

StudySpec StudySpec::resolve(const std::string& study_yaml, const std::string& source_name,
                             const SpecDefaults& defaults, std::uint32_t objective_version) {
  const YamlReader r = YamlReader::from_string(study_yaml, source_name);
  const std::optional<RobotDescription> robot = study_robot(r);
  const std::optional<bo::SearchSpace> space = robot ? std::optional(robot_space(*robot)) : std::nullopt;
  // The study's own keys, with file:line errors (a robot's space for `fixed` and `constraints`).
  const StudyConfig config = load_study_config_text(study_yaml, source_name, space ? &*space : nullptr);
  nlohmann::json tree = nlohmann::json::object();
  tree["objective_version"] = objective_version;
  tree[kStudy] = study_section(r.node());
  // A transfer or multi_fidelity study's first robot rollout is the transferred simulated optimum
  // (bo::HardwareOptimizer::start_point), so by default the robot starts once the whole simulated
  // exploration is in: started after the initial design, that "optimum" is the best random point, which in
  // the sim-to-hardware benchmark cost 0.83-1.24 on the robot against 0.42-0.47 for the simulation's answer
  // (docs/optimizer.md). Written into the spec, as every other default a spec resolves: a spec stored
  // before this default, which lacks the key, keeps the old one (the initial design) and replays as it ran.
  const bool model_based = config.hardware.strategy == HardwareStrategy::kTransfer ||
                           config.hardware.strategy == HardwareStrategy::kMultiFidelity;
  if (model_based && !tree[kStudy]["hardware"].contains("start_after")) {
    tree[kStudy]["hardware"]["start_after"] = static_cast<double>(config.budget);
  }
  if (robot) {
    if (r.has(kModel)) {
      r.fail(kModel, fmt::format("a study of robot '{}' takes its model from the robot's description; to change a "
                                 "value, copy the robot's folder, edit its robot.yaml and name the copy: robot: "
                                 "path/to/robot.yaml",
                                 robot->name));
    }
    if (const auto problem = name_problem(robot->name, 63)) r.fail("robot", fmt::format("the robot's name {}", *problem));
    tree[kStudy]["robot"] = robot->name;  // the name, not the path it was found at: the content is below
    tree[kRobot] = {{"name", robot->name}, {"robot_yaml", robot->yaml_text}, {"urdf", robot->urdf_text}};
  }

  nlohmann::json model = default_tree(defaults.model_path);
  nlohmann::json settings = default_tree(defaults.rollout_settings_path);
  // A rollout's length is the study's (`rollout: {entrain_s, eval_s}`), never the settings file's.
  settings.erase("entrain_s");
  settings.erase("eval_s");
  nlohmann::json base = default_tree(defaults.base_parameters_path);
  if (base.contains("params")) base = nlohmann::json(base["params"]);
  // Every CPG parameter gets a value, so a spec never depends on a worker's compiled-in defaults.
  for (const auto& [name, value] : to_map(CpgParameters{})) {
    if (!base.contains(name)) base[name] = value;
  }
  // A robot's default preset walks: its values are the study's base, under the study's own overrides.
  if (robot && robot->presets.count("default") > 0) {
    for (const auto& [name, value] : robot->presets.at("default")) base[name] = value;
  }
  if (robot) {
    // No model section: the robot's description is the model.
  } else if (r.has(kModel) && r.node()[kModel].IsScalar()) {
    // `model: FILE`: the client sent the file's content (model_file.hpp); its errors name that file's lines.
    const std::string file = r.node()[kModel].Scalar();
    if (!r.has(kModelFileTextKey)) {
      r.fail(kModel, fmt::format("'{}' names a model file, and this submit does not carry its content (`cpgmatch study "
                                 "submit` reads the file beside the study file and sends it)",
                                 file));
    }
    const YamlReader model_file = YamlReader::from_string(r.require_string(kModelFileTextKey), file);
    (void)sim::parse_model_file(model_file);  // its errors name the model file's own lines, not the merged text's
    merge_overrides(model, model_file);
  } else if (r.has(kModel)) {
    (void)sim::parse_model_file(r.child(kModel));  // errors name the study file's lines
    merge_overrides(model, r.child(kModel));
  }
  if (r.has(kSettings)) merge_overrides(settings, r.child(kSettings));
  if (r.has(kBaseParameters)) merge_overrides(base, r.child(kBaseParameters));
  numbers_to_double(model);
  numbers_to_double(settings);
  numbers_to_double(base);
  if (!robot) tree[kModel] = std::move(model);
  tree[kSettings] = std::move(settings);
  tree[kBaseParameters] = std::move(base);
  StudySpec spec(std::move(tree), source_name);
  // A spec travels whole in one DDS sample (idl/cpgmatch_msgs.idl, StudySpecSample::spec_json).
  if (spec.canonical_json().size() > kMaxSpecJsonBytes) {
    r.fail(robot ? "robot" : "name",
           fmt::format("the study's spec is {} bytes, more than one spec sample carries ({}){}", spec.canonical_json().size(),
                       kMaxSpecJsonBytes, robot ? ": shorten the robot's URDF or robot.yaml (comments, visual elements)" : ""));
  }
  // Constraints that leave too little of the space for the initial design are refused here, at the
  // constraints' line, before a service stores the study: refused only when the optimizer was made, the
  // study stayed stored and "running" with 0 trials (issue 34).
  if (!spec.config().constraints.empty()) {
    try {
      (void)bo::BayesianOptimizer(spec.config().space, spec.config().optimizer);
    } catch (const InputError& e) {
      r.fail("constraints", e.what());
    }
  }
  return spec;
}

StudySpec StudySpec::from_json_text(const std::string& canonical_json, const std::string& source_name) {
  nlohmann::json tree;
  try {
    // A spec is a few levels deep; a sample nested thousands deep (64 kB allow 32k levels) would exhaust a
    // worker's stack in the recursive code below: refused while parsing.
    constexpr int kMaxDepth = 16;
    tree = nlohmann::json::parse(canonical_json, [&](int depth, nlohmann::json::parse_event_t, nlohmann::json&) {
      if (depth > kMaxDepth) throw InputError(fmt::format("{}: study spec nested deeper than {} levels", source_name, kMaxDepth));
      return true;
    });
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{}: study spec is not JSON: {}", source_name, e.what()));
  }
  return StudySpec(std::move(tree), source_name);
}

StudySpec::StudySpec(nlohmann::json tree, const std::string& source_name) : tree_(std::move(tree)) {
  const bool of_robot = tree_.contains(kRobot);
  for (const char* section : {kStudy, of_robot ? kRobot : kModel, kSettings, kBaseParameters}) {
    if (!tree_.contains(section) || !tree_[section].is_object()) {
      throw InputError(fmt::format("{}: study spec has no '{}' mapping", source_name, section));
    }
  }
  if (of_robot && tree_.contains(kModel)) {
    throw InputError(fmt::format("{}: study spec has both a robot and a model; a robot's spec has no model", source_name));
  }
  if (!tree_.contains("objective_version") || !tree_["objective_version"].is_number_unsigned()) {
    throw InputError(fmt::format("{}: study spec has no objective_version", source_name));
  }
  objective_version_ = tree_["objective_version"].get<std::uint32_t>();
  canonical_ = tree_.dump();
  sha256_ = sha256_hex(canonical_);
  key_ = std::strtoull(sha256_.substr(0, 16).c_str(), nullptr, 16);
  std::optional<bo::SearchSpace> space;
  if (of_robot) {
    robot_ = robot_of_tree(tree_[kRobot], source_name);
    space = robot_space(*robot_);
  }
  config_ = load_study_config_text(json_to_yaml(tree_[kStudy]), source_name + " (study)", space ? &*space : nullptr);
  if (robot_ && config_.robot != robot_->name) {
    throw InputError(fmt::format("{}: study spec's study names robot '{}' but holds robot '{}'", source_name, config_.robot, robot_->name));
  }
  model_ = robot_ ? sim::planar_leg_model(*robot_) : sim::parse_model_file(reader_of(tree_[kModel], source_name + " (model)"));
  settings_ = parse_rollout_settings(reader_of(tree_[kSettings], source_name + " (rollout_settings)"));
  if (robot_) apply_robot_legs(settings_.controller, *robot_);  // its legs, groups and gaits
  settings_.entrain_s = config_.entrain_s;
  settings_.eval_s = config_.eval_s;
  base_parameters_ = parse_parameters(reader_of(tree_[kBaseParameters], source_name + " (base_parameters)"));
  bind_constraints(config_, to_map(base_parameters_));  // fixed and base parameters take their values
}

std::string StudySpec::to_study_yaml() const {
  nlohmann::json file = tree_[kStudy];
  if (robot_) {
    file[kRobotYamlTextKey] = tree_[kRobot]["robot_yaml"];  // the same texts, so the same hash
    file[kRobotUrdfTextKey] = tree_[kRobot]["urdf"];
  } else if (file.contains(kModel) && file[kModel].is_string()) {
    file[kModelFileTextKey] = json_to_yaml(tree_[kModel]);  // the same content, so the same hash
  } else {
    file[kModel] = tree_[kModel];
  }
  file[kSettings] = tree_[kSettings];
  file[kBaseParameters] = tree_[kBaseParameters];
  return fmt::format("# study spec {} (objective version {}): resubmitting this file gives the same spec\n{}",
                     sha256_, objective_version_, json_to_yaml(file));
}

}  // namespace cpgmatch::study
