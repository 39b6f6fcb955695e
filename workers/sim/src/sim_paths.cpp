// Where the shipped defaults are: no physics here, so that what only reads a model (the study spec, the
// optimizer service, the robot agent) links none.
#include <cstdlib>
#include <string>

#include "cpgmatch/sim/sim_rollout.hpp"

namespace cpgmatch::sim {

std::string config_dir() {
  if (const char* env = std::getenv("CPGMATCH_CONFIG_DIR"); env && *env) return env;
  return CPGMATCH_CONFIG_DIR;
}
std::string default_model_path() { return config_dir() + "/model/morti.yaml"; }
std::string default_rollout_settings_path() { return config_dir() + "/rollout.yaml"; }
std::string default_params_path() { return config_dir() + "/params/default.yaml"; }

}  // namespace cpgmatch::sim
