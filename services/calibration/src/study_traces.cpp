#include "cpgmatch/calibration/study_traces.hpp"

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::calibration {
namespace {

// A JSON scalar as YAML: strings double-quoted (a JSON string is a valid YAML one), numbers in their
// shortest round-trip form with a decimal point, so that they read back as the same doubles.
std::string yaml_scalar(const nlohmann::json& v) {
  if (v.is_number_float()) {
    std::string text = fmt::format("{}", v.get<double>());
    if (text.find_first_of(".eEn") == std::string::npos) text += ".0";
    return text;
  }
  return v.dump();
}

}  // namespace

std::string model_yaml_of(const nlohmann::json& model_tree) {
  std::string out;
  for (const auto& [section, entries] : model_tree.items()) {
    if (!entries.is_object()) {
      out += fmt::format("{}: {}\n", section, yaml_scalar(entries));
      continue;
    }
    out += section + ":\n";
    for (const auto& [key, entry] : entries.items()) {
      if (entry.is_object() && entry.contains("value")) {
        out += fmt::format("  {}: {{value: {}{}}}\n", key, yaml_scalar(entry["value"]),
                           entry.contains("source") ? ", source: " + yaml_scalar(entry["source"]) : "");
      } else {
        out += fmt::format("  {}: {}\n", key, entry.is_object() ? entry.dump() : yaml_scalar(entry));
      }
    }
  }
  return out;
}

StudyTraces load_study_traces(const study::StudyStore& store, int study_id, double window_s) {
  const std::optional<study::StoredStudy> stored = store.load(study_id);
  const std::string where = fmt::format("--store {} --study {}", store.path(), study_id);
  if (!stored) throw InputError(fmt::format("{}: no such study", where));
  if (stored->spec.json.empty()) throw InputError(fmt::format("{}: the study has no spec (an older store?)", where));
  const study::StudySpec spec = study::StudySpec::from_json_text(stored->spec.json, where);
  StudyTraces out;
  // The spec's model is what every rollout of it ran on: for a robot, planar_leg_model of its description.
  out.model = spec.model();
  out.robot = spec.robot();
  if (!out.robot) out.model_yaml = model_yaml_of(spec.tree()["model"]);
  out.model_source = fmt::format("{} study {} (spec {}{})", store.path(), study_id, spec.sha256().substr(0, 16),
                                 out.robot ? ", robot " + out.robot->name : "");
  for (study::StoredTrace& kept : store.load_traces(study_id)) {
    domain::RolloutTrace& t = kept.trace;
    const std::string name = t.trace.source;
    const study::StoredTrial* trial = nullptr;
    for (const auto& candidate : stored->trials) {
      if (candidate.trial_id == t.id.trial_id) trial = &candidate;
    }
    const std::optional<domain::RolloutReport> report = trial ? study::stored_report(*trial) : std::nullopt;
    if (!report || !report->ok() || trial->attempt != t.id.attempt || trial->worker_id != t.worker_id) {
      out.skipped.push_back(name + ": not the attempt its trial counted as a measured rollout");
      continue;
    }
    RolloutSettings settings = spec.rollout_settings();
    settings.controller.control_rate_hz = t.control_rate_hz;  // the robot's own rate (HardwareRunner)
    CpgParameters params = spec.base_parameters();
    for (const auto& [p, value] : t.parameters) set_parameter(params, p, value, name);
    out.traces.push_back(prepare_trace(std::move(t.trace), params, settings, sim::TerrainSpec::parse(t.terrain), t.seed, window_s));
    out.sources.push_back(name);
  }
  if (out.traces.empty()) {
    throw InputError(fmt::format("{}: no hardware trace to fit ({} kept, none of a counted, measured rollout)", where,
                                 out.skipped.size()));
  }
  return out;
}

}  // namespace cpgmatch::calibration
