#include "cpgmatch/sim/sim_rollout.hpp"

#include "cpgmatch/sim/ode_plant.hpp"

namespace cpgmatch::sim {

RolloutResult run_sim_rollout(const SimRolloutJob& job, const TraceSink& trace) {
  OdePlant plant(job.model, job.terrain, job.seed);
  return run_rollout(plant, job.params, job.settings, job.seed, trace);
}

}  // namespace cpgmatch::sim
