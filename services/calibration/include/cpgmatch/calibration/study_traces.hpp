// The traces a study's store holds (StudyStore::load_traces), ready to fit: each counted hardware rollout's
// trace with the CPG parameters, control rate, seed and terrain it ran with, and the study's spec for the
// rest (the model the fit starts from, the controller, the contact sensing). `cpgmatch calibrate --store`.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "cpgmatch/calibration/calibration.hpp"
#include "cpgmatch/study/study_store.hpp"

namespace cpgmatch::calibration {

struct StudyTraces {
  sim::PlanarLegModel model;   // the study spec's model: where the fit starts
  // A study of a robot (`robot:`): its description, whose model `model` is (sim::planar_leg_model, as every
  // rollout of the spec builds it) and which calibrated_robot rewrites. None for a study of a model file.
  std::optional<RobotDescription> robot;
  std::string model_yaml;  // a model file's study: its model as YAML, one line per value (what calibrated_model_text rewrites)
  std::string model_source;  // "STORE study ID (spec SHA)", for messages and the calibrated file's header
  std::vector<CalibrationTrace> traces;
  std::vector<std::string> sources;  // one per trace
  std::vector<std::string> skipped;  // kept traces not used, each with the reason
};

// The study's traces whose attempt is the one its trial counted and whose rollout measured the gait (a
// refused or faulted attempt's trace is not the robot's answer to the commands). `window_s` keeps each
// trace's first seconds (prepare_trace). A robot's study replays on the robot's model with its legs (the
// spec's settings carry them) and its default preset under the study's base parameters. Throws InputError naming the store and study when the study is
// not there, has no spec, or has no usable trace.
StudyTraces load_study_traces(const study::StudyStore& store, int study_id, double window_s);

// A spec's model tree ({section: {key: {value, source}}}) as model YAML, one line per value.
std::string model_yaml_of(const nlohmann::json& model_tree);

}  // namespace cpgmatch::calibration
