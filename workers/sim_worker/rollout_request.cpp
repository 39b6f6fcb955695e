#include "rollout_request.hpp"

#include <fmt/format.h>

#include "cpgmatch/domain/report_json.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/study/spec_rollout.hpp"

namespace cpgmatch::worker {

nlohmann::json rollout_request(const domain::Candidate& c, const study::StudySpec& spec, bool with_spec) {
  nlohmann::json params = nlohmann::json::object();
  for (const auto& [name, value] : c.parameters) params[name] = value;
  nlohmann::json request = {{"params", params},
                            {"entrain_s", c.rollout.entrain_s},
                            {"eval_s", c.rollout.eval_s},
                            {"terrain", c.rollout.terrain},
                            {"seed", c.rollout.seed},
                            {"spec_key", study::spec_key_hex(spec.key())}};
  if (with_spec) request["spec"] = spec.canonical_json();
  return request;
}

nlohmann::json run_rollout(const study::StudySpec& spec, const nlohmann::json& request) {
  sim::SimRolloutJob job;
  try {
    std::map<std::string, double> params;
    for (const auto& [name, value] : request.at("params").items()) params[name] = value.get<double>();
    job = study::sim_job_for(spec, params, request.at("terrain").get<std::string>(), request.at("seed").get<std::uint64_t>(),
                             request.at("entrain_s").get<double>(), request.at("eval_s").get<double>());
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("rollout request: {}", e.what()));
  }
  const RolloutResult result = sim::run_sim_rollout(job);
  return domain::to_json(domain::report_of(result));  // outcome and (for a divergence) the error
}

nlohmann::json run_rollout_request(const nlohmann::json& request) {
  std::string spec_text;
  try {
    spec_text = request.at("spec").get<std::string>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("rollout request: {}", e.what()));
  }
  return run_rollout(study::StudySpec::from_json_text(spec_text, "rollout request"), request);
}

}  // namespace cpgmatch::worker
