// Everything needed to run one simulated rollout, and the call that runs it.
#pragma once

#include <cstdint>
#include <string>

#include "cpgmatch/rollout.hpp"
#include "cpgmatch/sim/morti_model.hpp"
#include "cpgmatch/sim/terrain.hpp"

namespace cpgmatch::sim {

struct SimRolloutJob {
  CpgParameters params;
  RolloutSettings settings;
  PlanarLegModel model;
  TerrainSpec terrain;
  std::uint64_t seed = 0;
};

// Builds a fresh ODE world for the job and runs it; deterministic for a given job.
RolloutResult run_sim_rollout(const SimRolloutJob& job, const TraceSink& trace = {});

// Default config paths shipped in configs/ (overridable with CPGMATCH_CONFIG_DIR at run time).
std::string config_dir();
std::string default_model_path();
std::string default_rollout_settings_path();
std::string default_params_path();

}  // namespace cpgmatch::sim
