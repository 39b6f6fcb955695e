// A BayesianOptimizer's saved state as JSON: what the study store keeps beside the observations so that a
// restarted service restores each study's model exactly, without refitting once per stored result.
#pragma once

#include <nlohmann/json.hpp>

#include "cpgmatch/bo/hardware_optimizer.hpp"
#include "cpgmatch/bo/optimizer.hpp"

namespace cpgmatch::bo {

nlohmann::json model_state_to_json(const ModelState& state);
// Throws (nlohmann's exceptions or std::runtime_error) for a tree that is not a saved state.
ModelState model_state_from_json(const nlohmann::json& j);

// A HardwareOptimizer's saved state, likewise (kept beside the study's ModelState).
nlohmann::json hardware_model_state_to_json(const HardwareModelState& state);
HardwareModelState hardware_model_state_from_json(const nlohmann::json& j);

}  // namespace cpgmatch::bo
