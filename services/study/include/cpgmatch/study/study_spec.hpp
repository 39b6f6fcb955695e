// A study specification: everything that decides what a rollout of the study computes, resolved and
// held *by content*, so that a study is a complete, self-describing experiment.
//
// A study file names only what differs from the release's defaults:
//
//   name: stiff-knee
//   budget: 60
//   model: {knee_spring: {stiffness_nm_per_rad: 20}}          # overrides onto configs/model/morti.yaml
//   rollout_settings: {cost: {weights: {feedback: 4}}}       # overrides onto configs/rollout.yaml
//   base_parameters: {frequency: 1.2}                         # overrides onto configs/params/default.yaml
//
// Resolving it (at submit, on the optimizer) merges those overrides onto the defaults and yields one
// canonical JSON tree:
//
//   {"objective_version": 1,
//    "study": {...the study file's own keys...},
//    "model": {...the whole robot model, each value with its source...},   (or, for `robot: NAME|PATH`,
//    "robot": {"name", "robot_yaml", "urdf"}: the robot's description, both texts as read; robot_file.hpp)
//    "rollout_settings": {...controller, feedback, contact sensing, cost weights...},
//    "base_parameters": {...every CPG parameter a study neither optimises nor fixes...}}
//
// The tree is stored verbatim with its SHA-256; candidates carry the first 64 bits of that hash (the DDS
// key of the cpgmatch/study_specs topic), workers fetch the tree by it and run exactly it. Two releases
// whose science computes different costs have different objective versions, so their specs never hash
// alike and never mix in one study.
//
// The typed loaders (study config, sim::PlanarLegModel, RolloutSettings) validate every section, so a spec
// that resolves is a spec a worker can run; the tree is what travels and what is stored.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "cpgmatch/params.hpp"
#include "cpgmatch/robot_description.hpp"
#include "cpgmatch/rollout.hpp"
#include "cpgmatch/sim/morti_model.hpp"
#include "cpgmatch/study/study_config.hpp"

namespace cpgmatch::study {

// Bumped whenever the science in common/ or the simulation changes what a rollout computes for the same
// spec (a new cost term, another contact model, a fixed bug in the feedback). Part of every spec's hash.
// History: 1 = every release so far, specs included: a store from before specs is migrated to version 1
// (its rollouts computed what this release computes; a diverged simulation is now reported as diverged
// instead of as a fall, which changes the cost of no rollout that ran). 2 = the knee motor runs within the
// same torque-speed line as the hip (issue 26; before, it moved at its no-load speed whatever torque it
// held), which changes the gait, hence the cost, of every rollout whose knee motor is loaded while it moves;
// reports carry the motors' energy from this version on. 3 = the planar joints constrain the plane's motion
// with two rows per pin and none for the rail (issue 32; before, three per pin and three for the rail, the
// extra ones repeating what the projection onto the plane keeps): the same constrained dynamics, solved with
// other round-off, so a cost moves in its last digits and a chaotic gait's further (docs/model.md, "Rollout
// speed").
inline constexpr std::uint32_t kObjectiveVersion = 3;
// What a store written before specs existed computed: every release before specs was version 1. Its studies
// are migrated with this version, not the current one, so a worker of another version refuses their
// candidates instead of mixing two objectives in one study.
inline constexpr std::uint32_t kVersionBeforeSpecs = 1;

// The largest canonical spec: it travels whole in one DDS sample (idl/cpgmatch_msgs.idl: string<65536>
// spec_json). A Morti spec is about 10 kB; a robot's adds its URDF and robot.yaml (14 kB for Morti's).
inline constexpr std::size_t kMaxSpecJsonBytes = 65536;

// Where a stored spec came from.
inline constexpr const char* kOriginSubmitted = "submitted";

// The files a spec's defaults are read from (the release's configs/ by default).
struct SpecDefaults {
  std::string model_path;
  std::string rollout_settings_path;
  std::string base_parameters_path;
  // The shipped defaults: $CPGMATCH_CONFIG_DIR, else the installed or source tree's configs/.
  static SpecDefaults shipped();
};

class StudySpec {
 public:
  // Resolves a study file's text onto `defaults`. Throws InputError naming file:line and field for a bad
  // study key, an override of a key the model or settings do not have, or a value out of range.
  static StudySpec resolve(const std::string& study_yaml, const std::string& source_name, const SpecDefaults& defaults,
                           std::uint32_t objective_version = kObjectiveVersion);
  // A stored or received canonical tree. Throws InputError when it does not parse or validate.
  static StudySpec from_json_text(const std::string& canonical_json, const std::string& source_name);

  const nlohmann::json& tree() const { return tree_; }
  const std::string& canonical_json() const { return canonical_; }
  // Hex SHA-256 of canonical_json(): the spec's identity in the store and in `study show`.
  const std::string& sha256() const { return sha256_; }
  // The first 8 bytes of the SHA-256, big-endian: the DDS key candidates carry.
  std::uint64_t key() const { return key_; }
  std::uint32_t objective_version() const { return objective_version_; }

  const StudyConfig& config() const { return config_; }
  // The study's robot (`robot:` in the study file), whose description built model() and the controller's
  // legs; none for a study of Morti's model file (configs/model/morti.yaml and its overrides).
  const std::optional<RobotDescription>& robot() const { return robot_; }
  const sim::PlanarLegModel& model() const { return model_; }
  const RolloutSettings& rollout_settings() const { return settings_; }  // entrain/eval: the study's
  const CpgParameters& base_parameters() const { return base_parameters_; }

  // A study file that `study submit` accepts and that resolves to this very spec (same hash): the study's
  // keys, then the whole model, settings and base parameters as overrides.
  std::string to_study_yaml() const;

 private:
  explicit StudySpec(nlohmann::json tree, const std::string& source_name);

  nlohmann::json tree_;
  std::string canonical_;
  std::string sha256_;
  std::uint64_t key_ = 0;
  std::uint32_t objective_version_ = 0;
  StudyConfig config_;
  std::optional<RobotDescription> robot_;
  sim::PlanarLegModel model_;
  RolloutSettings settings_;
  CpgParameters base_parameters_;
};

// Hex SHA-256 of a text (a spec's canonical JSON).
std::string sha256_hex(const std::string& text);

// "1a2b3c4d5e6f7a8b": a spec key as 16 hex digits (logs, refusals).
std::string spec_key_hex(std::uint64_t key);

// YAML <-> JSON for spec trees. Scalars become booleans, integers, doubles or strings as YAML 1.2's core
// schema reads them; doubles are written back in their shortest round-trip form, so a tree survives
// JSON -> YAML -> JSON unchanged to the bit.
nlohmann::json yaml_to_json(const YAML::Node& node);
std::string json_to_yaml(const nlohmann::json& tree);

}  // namespace cpgmatch::study
