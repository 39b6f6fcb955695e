// JSON form of a rollout result, as printed by `cpgmatch rollout --json` and stored by studies.
#pragma once

#include <nlohmann/json.hpp>

#include "cpgmatch/rollout.hpp"

namespace cpgmatch::cli {

nlohmann::json to_json(const RolloutResult& r);
nlohmann::json params_to_json(const CpgParameters& p);

}  // namespace cpgmatch::cli
