#include "cpgmatch/study/spec_rollout.hpp"

#include "cpgmatch/seeds.hpp"

namespace cpgmatch::study {

sim::SimRolloutJob sim_job_for(const StudySpec& spec, const std::map<std::string, double>& parameters,
                               const std::string& terrain, std::uint64_t seed, double entrain_s, double eval_s) {
  sim::SimRolloutJob job;
  job.model = spec.model();
  job.settings = spec.rollout_settings();
  job.settings.entrain_s = entrain_s;
  job.settings.eval_s = eval_s;
  job.params = spec.base_parameters();
  for (const auto& [name, value] : parameters) set_parameter(job.params, name, value, "trial");
  job.terrain = sim::TerrainSpec::parse(terrain);
  job.seed = seed;
  return job;
}

std::uint64_t trial_seed(const StudySpec& spec, int trial_id) {
  return derived_seed(spec.config().optimizer.seed, static_cast<std::uint64_t>(trial_id));
}

}  // namespace cpgmatch::study
