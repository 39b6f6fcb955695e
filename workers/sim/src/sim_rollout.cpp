#include "cpgmatch/sim/sim_rollout.hpp"

#include <cstdlib>

#include "cpgmatch/sim/ode_plant.hpp"

namespace cpgmatch::sim {

RolloutResult run_sim_rollout(const SimRolloutJob& job, const TraceSink& trace) {
  OdePlant plant(job.model, job.terrain, job.seed);
  return run_rollout(plant, job.params, job.settings, job.seed, trace);
}

std::string config_dir() {
  if (const char* env = std::getenv("CPGMATCH_CONFIG_DIR"); env && *env) return env;
  return CPGMATCH_CONFIG_DIR;
}
std::string default_model_path() { return config_dir() + "/model/morti.yaml"; }
std::string default_rollout_settings_path() { return config_dir() + "/rollout.yaml"; }
std::string default_params_path() { return config_dir() + "/params/default.yaml"; }

}  // namespace cpgmatch::sim
