#include "cpgmatch/study/study_config.hpp"
#include "cpgmatch/study/model_file.hpp"
#include "cpgmatch/study/robot_file.hpp"
#include "cpgmatch/study/study_file_keys.hpp"

#include <algorithm>
#include <set>

#include <yaml-cpp/yaml.h>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/sim/terrain.hpp"
#include "cpgmatch/text.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch::study {

namespace {

StudyConfig parse(const YamlReader& r, const bo::SearchSpace* default_space);

}  // namespace

std::string to_string(HardwareStrategy s) {
  switch (s) {
    case HardwareStrategy::kValidate: return "validate";
    case HardwareStrategy::kTransfer: return "transfer";
    case HardwareStrategy::kMultiFidelity: return "multi_fidelity";
    case HardwareStrategy::kNone: break;
  }
  return "none";
}

void bind_constraints(StudyConfig& config, const std::map<std::string, double>& base_parameters) {
  config.optimizer.constraints =
      config.constraints.empty()
          ? nullptr
          : std::make_shared<const bo::ParameterConstraints>(config.constraints, config.space, base_parameters);
}

StudyConfig load_study_config(const std::string& path) { return parse(YamlReader::from_file(path), nullptr); }

StudyConfig load_study_config_text(const std::string& text, const std::string& source_name,
                                   const bo::SearchSpace* default_space) {
  return parse(YamlReader::from_string(text, source_name), default_space);
}

namespace {

// Limits on a study file. A study name travels in a 64-byte DDS string; a million rollouts of 20 s is
// over 200 days of one core's work, far beyond any real study, while the optimizer's memory and the
// initial design grow with the budget (an unbounded budget let one file exhaust the service's memory).
constexpr std::size_t kMaxStudyNameBytes = 64;
constexpr int kMaxBudget = 100'000;
constexpr double kMaxRolloutPartS = 3600.0;  // entrainment or evaluation, seconds

// A study key that is a list of strings (`constraints`, `enqueue`): each with its own line for errors.
template <typename Each>
void for_each_string(const YamlReader& r, const std::string& key, const Each& each) {
  if (!r.has(key)) return;
  const YAML::Node list = r.node()[key];
  if (!list.IsSequence()) r.fail(key, "must be a list of strings, e.g. [\"a\", \"b\"]");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YAML::Node item = list[i];
    const std::string where = item.Mark().line >= 0 ? fmt::format("{}:{}", r.source(), item.Mark().line + 1) : r.source();
    if (!item.IsScalar()) {
      throw InputError(fmt::format("{}: field '{}[{}]': must be a string", where, r.field(key), i));
    }
    each(i, item.Scalar(), where);
  }
}

// `constraints: [...]`: parsed once here, with every CPG parameter name known (a fixed or base parameter
// takes its value in the study). Needs the space parsed: a constraint on no searched parameter is refused.
void parse_constraints(const YamlReader& r, StudyConfig& s) {
  std::set<std::string> known;
  for (const auto& info : parameter_table()) known.insert(std::string(info.name));
  constexpr std::size_t kMaxConstraints = 64;
  for_each_string(r, "constraints", [&](std::size_t i, const std::string& text, const std::string& where) {
    const std::string field = fmt::format("{}[{}]", r.field("constraints"), i);
    if (i >= kMaxConstraints) throw InputError(fmt::format("{}: field '{}': more than {} constraints", where, field, kMaxConstraints));
    if (text.size() > 1024) throw InputError(fmt::format("{}: field '{}': longer than 1024 characters", where, field));
    try {
      s.constraints.push_back(bo::Constraint::parse(text, known));
    } catch (const bo::ConstraintSyntaxError& e) {
      throw InputError(fmt::format("{}: field '{}': {} of \"{}\"", where, field, e.what(), text));
    }
    // A divisor that can be 0 makes the constraint inf or NaN there: refused, not silently infeasible. A name
    // that is not searched counts with its fixed value, or its whole valid range (its base value comes later).
    const auto range_of = [&](const std::string& name) -> std::pair<double, double> {
      if (const int d = s.space.index_of(name); d >= 0) {
        const auto& dim = s.space.dimensions()[static_cast<std::size_t>(d)];
        return {dim.low, dim.high};
      }
      if (const auto f = s.space.fixed().find(name); f != s.space.fixed().end()) return {f->second, f->second};
      const ParameterInfo& info = parameter_info(name);
      return {info.low, info.high};
    };
    if (const auto why = s.constraints.back().division_by_zero(range_of)) {
      throw InputError(fmt::format("{}: field '{}': \"{}\" {} within the search space (a division by zero has no "
                                   "value; bound the divisor away from 0)", where, field, text, *why));
    }
    const auto& names = s.constraints.back().names();
    if (std::none_of(names.begin(), names.end(), [&](const std::string& n) { return s.space.index_of(n) >= 0; })) {
      throw InputError(fmt::format("{}: field '{}': \"{}\" uses no searched parameter: it is true or false for "
                                   "every trial (constrain a searched one, or change the fixed values)",
                                   where, field, text));
    }
  });
}

// `hardware: {strategy, budget, ...}` (study_config.hpp, HardwareConfig). Needs budget, initial_points,
// lockstep, explore_on and validation already parsed.
void parse_hardware(const YamlReader& r, StudyConfig& s) {
  const YamlReader h = r.child("hardware");
  const std::string name = h.require_string("strategy");
  if (name == "validate") {
    s.hardware.strategy = HardwareStrategy::kValidate;
  } else if (name == "transfer") {
    s.hardware.strategy = HardwareStrategy::kTransfer;
  } else if (name == "multi_fidelity") {
    s.hardware.strategy = HardwareStrategy::kMultiFidelity;
  } else {
    h.fail("strategy", fmt::format("'{}' is not a hardware strategy (validate | transfer | multi_fidelity)", name));
  }
  if (r.has("validation")) {
    r.fail("hardware", "give either `hardware` or its older spelling `validation`, not both");
  }
  if (s.hardware.strategy == HardwareStrategy::kValidate) {
    // The validation phase under its new name: the same sets, the same checks.
    h.reject_unknown_keys({"strategy", "budget", "spread"});
    s.validation.enabled = true;
    s.validation.hardware_sets = h.get_int_in("budget", s.validation.hardware_sets, 1, 1000);
    s.validation.spread = h.get_double_in("spread", s.validation.spread, 0.0, 1.0);
    s.hardware.budget = s.validation.hardware_sets;
    return;
  }
  h.reject_unknown_keys({"strategy", "budget", "max_fall_probability", "start_after", "safe_margin", "safe_beta"});
  // A study of more robot rollouts than this is a hardware-only study (`explore_on: hardware`).
  s.hardware.budget = h.get_int_in("budget", s.hardware.budget, 1, 1000);
  s.hardware.max_fall_probability = h.get_double_in("max_fall_probability", s.hardware.max_fall_probability, 0.0, 1.0);
  // Upper ends: a margin of 10 (a proposal 11 times the best robot cost) or a beta of 10 standard deviations
  // no longer bound anything a study would notice; larger values are more likely typos than intent.
  s.hardware.safe_margin = h.get_double_in("safe_margin", s.hardware.safe_margin, 0.0, 10.0);
  s.hardware.safe_beta = h.get_double_in("safe_beta", s.hardware.safe_beta, 0.0, 10.0);
  // Not before the initial design is in: hardware trials then never take trial ids of the initial design,
  // and the simulation's model is more than random points.
  s.hardware.start_after =
      h.get_int_in("start_after", s.optimizer.initial_points, std::max(2, s.optimizer.initial_points), s.budget);
  if (s.explore_on == WorkerKindWanted::kHardware) {
    r.fail("hardware", "transfer and multi_fidelity learn from simulated rollouts: explore_on must be simulation");
  }
  if (s.lockstep > 0) {
    // Lockstep numbers a study's proposals by trial id; hardware trials would take ids in between.
    r.fail("hardware", "lockstep studies cannot use transfer or multi_fidelity (yet): remove lockstep");
  }
}

StudyConfig parse(const YamlReader& r, const bo::SearchSpace* default_space) {
  // The keys the manual lists (study_file_keys.cpp); `model`, `rollout_settings` and `base_parameters` are the
  // study's objective, resolved by StudySpec (study_spec.hpp) and checked there. Besides them, the text of a
  // `model: FILE` that the submitting client appends (model_file.hpp): not a key people write.
  const auto keys = top_level_study_file_keys();
  std::set<std::string> known(keys.begin(), keys.end());
  known.insert(kModelFileTextKey);
  known.insert(kRobotYamlTextKey);
  known.insert(kRobotUrdfTextKey);
  r.reject_unknown_keys(known);
  StudyConfig s;
  if (default_space != nullptr) s.space = *default_space;  // the study's robot's (study_spec.cpp)
  // Every key has a range, checked here before anything is stored (see docs/dds.md, "Limits").
  s.name = r.require_string("name");
  if (const auto problem = name_problem(s.name, kMaxStudyNameBytes)) r.fail("name", *problem);
  s.budget = r.get_int_in("budget", s.budget, 1, kMaxBudget);
  s.optimizer.initial_points = r.get_int_in("initial_points", 15, 1, s.budget);
  s.optimizer.budget = s.budget;
  try {
    s.optimizer.acquisition = bo::acquisition_from_string(r.get_string("acquisition", "gp_hedge"));
  } catch (const InputError& e) {
    r.fail("acquisition", e.what());
  }
  try {
    s.optimizer.initial_design = bo::initial_design_from_string(r.get_string("initial_design", "random"));
    s.optimizer.liar = bo::liar_from_string(r.get_string("liar", "believer"));
  } catch (const InputError& e) {
    r.fail(r.has("liar") ? "liar" : "initial_design", e.what());
  }
  // Studies model log(cost) by default: a rollout's cost is > 0 by construction (J_distance >= 1/x > 0) and
  // spans a fall cliff (13-19 against 0.4-2) that would set a linear GP's amplitude (docs/optimizer.md).
  try {
    s.optimizer.cost_transform = bo::cost_transform_from_string(r.get_string("cost_transform", "log"));
  } catch (const InputError& e) {
    r.fail("cost_transform", e.what());
  }
  // Optional: learn where rollouts fall and weight proposals by the chance of not falling (docs/optimizer.md).
  // Off by default: over 5 seeds of the paper's study it did not lower the falls significantly.
  s.optimizer.fall_model = r.get_bool("fall_model", false);
  const int seed = r.get_int_in("seed", 0, 0, 2'000'000'000);
  s.optimizer.seed = static_cast<std::uint64_t>(seed);
  if (r.has("rollout")) {
    const YamlReader ro = r.child("rollout");
    ro.reject_unknown_keys({"entrain_s", "eval_s"});
    s.entrain_s = ro.get_double_in("entrain_s", s.entrain_s, 0.0, kMaxRolloutPartS);
    s.eval_s = ro.get_double_in("eval_s", s.eval_s, 0.01, kMaxRolloutPartS);
  }
  s.lease_s = r.get_double_in("lease_s", 0.0, 0.0, 86400.0);  // 0: derived from the rollout length
  s.lockstep_given = r.has("lockstep");
  s.lockstep = r.get_int_in("lockstep", 0, 0, 1024);  // more rollouts at once than this is a cluster: go async
  s.robot = r.get_string("robot", "");
  if (r.has("robot")) {
    // A shipped robot's name (a worker id's rule), or the path of a robot of the user's own (robot_file.hpp),
    // which the spec replaces by that robot's name.
    if (const auto problem = name_problem(s.robot, names_shipped_robot(s.robot) ? 63 : 1024)) r.fail("robot", *problem);
  }
  const std::string explore_on = r.get_string("explore_on", "simulation");
  if (explore_on == "hardware") {
    s.explore_on = WorkerKindWanted::kHardware;
  } else if (explore_on != "simulation") {
    r.fail("explore_on", fmt::format("'{}' is not a worker kind (simulation | hardware)", explore_on));
  }
  if (r.has("validation")) {
    const YamlReader v = r.child("validation");
    v.reject_unknown_keys({"hardware_sets", "spread"});
    s.validation.enabled = true;
    // More sets than this is no longer a validation but a second study on the robot.
    s.validation.hardware_sets = v.get_int_in("hardware_sets", s.validation.hardware_sets, 1, 1000);
    // A relative spread of 1 already reaches zero; beyond it a parameter could change sign.
    s.validation.spread = v.get_double_in("spread", s.validation.spread, 0.0, 1.0);
    // The older spelling of `hardware: {strategy: validate, budget: N, spread: S}`.
    s.hardware.strategy = HardwareStrategy::kValidate;
    s.hardware.budget = s.validation.hardware_sets;
  }
  if (r.has("hardware")) parse_hardware(r, s);
  s.terrain = r.get_string("terrain", s.terrain);
  try {
    (void)sim::TerrainSpec::parse(s.terrain);
  } catch (const InputError& e) {
    r.fail("terrain", e.what());
  }
  if (r.has("parameters")) {
    s.space = bo::SearchSpace::from_reader(r);
  } else if (r.has("fixed")) {
    // On top of the default space's own fixed values (a robot's preset on what it does not search).
    std::map<std::string, double> fixed = default_space != nullptr ? default_space->fixed() : std::map<std::string, double>{};
    r.child("fixed").for_each_number([&](const std::string& k, double v, const std::string&) { fixed[k] = v; });
    try {
      s.space = bo::SearchSpace(
          (default_space != nullptr ? *default_space : bo::SearchSpace::paper_cpg_space()).dimensions(), fixed);
    } catch (const InputError& e) {
      r.fail("fixed", e.what());
    }
  }
  // Every optimised or fixed name must be a CPG parameter, with bounds inside its valid range.
  for (const auto& d : s.space.dimensions()) {
    const ParameterInfo* info = nullptr;
    try {
      info = &parameter_info(d.name);
    } catch (const InputError& e) {
      r.fail("parameters", e.what());
    }
    if (d.low < info->low || d.high > info->high) {
      r.fail("parameters", fmt::format("'{}' range [{}, {}] exceeds its valid range [{}, {}]", d.name, d.low, d.high,
                                       info->low, info->high));
    }
  }
  for (const auto& [name, value] : s.space.fixed()) {
    CpgParameters p;
    try {
      set_parameter(p, name, value, "fixed");
    } catch (const InputError& e) {
      r.fail("fixed", e.what());
    }
  }
  parse_constraints(r, s);
  for_each_string(r, "enqueue", [&](std::size_t i, const std::string& file, const std::string& where) {
    if (file.empty() || i >= 64) {
      throw InputError(fmt::format("{}: field '{}[{}]': {}", where, r.field("enqueue"), i,
                                   file.empty() ? "an empty file name" : "more than 64 gaits"));
    }
    s.enqueue_files.push_back(file);
  });
  return s;
}

}  // namespace
}  // namespace cpgmatch::study
