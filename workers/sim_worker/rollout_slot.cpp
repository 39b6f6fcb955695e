#include "rollout_slot.hpp"

#include <chrono>
#include <cmath>
#include <thread>

#include <fmt/format.h>

#include "cpgmatch/command_objective.hpp"
#include "cpgmatch/domain/report_json.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/study/spec_rollout.hpp"

namespace cpgmatch::worker {

namespace {

domain::RolloutReport failed(const domain::Candidate& c, const SlotOptions& o, const std::string& why,
                             domain::Outcome outcome = domain::Outcome::kError) {
  domain::RolloutReport r;
  r.id = c.id;
  r.worker_id = o.worker_id;
  r.worker_kind = domain::WorkerKind::kSimulation;
  r.outcome = outcome;
  r.error = why;
  return r;
}

// A rollout part longer than this is refused (a study file allows at most this much, study_config.cpp): a
// candidate asking for 1e308 s would otherwise hold a slot until its lease runs out.
constexpr double kMaxRolloutPartS = 3600.0;

std::optional<std::string> check_spec(const domain::RolloutConditions& s) {
  if (!std::isfinite(s.entrain_s) || s.entrain_s < 0.0 || s.entrain_s > kMaxRolloutPartS) {
    return fmt::format("rollout.entrain_s = {} (must be in [0, {}] s)", s.entrain_s, kMaxRolloutPartS);
  }
  if (!std::isfinite(s.eval_s) || s.eval_s <= 0.0 || s.eval_s > kMaxRolloutPartS) {
    return fmt::format("rollout.eval_s = {} (must be in (0, {}] s)", s.eval_s, kMaxRolloutPartS);
  }
  try {
    (void)sim::TerrainSpec::parse(s.terrain);
  } catch (const InputError& e) {
    return fmt::format("rollout.terrain: {}", e.what());
  }
  return std::nullopt;
}

}  // namespace

nlohmann::json rollout_request(const domain::Candidate& c, const study::StudySpec& spec) {
  nlohmann::json params = nlohmann::json::object();
  for (const auto& [name, value] : c.parameters) params[name] = value;
  return {{"params", params},
          {"entrain_s", c.rollout.entrain_s},
          {"eval_s", c.rollout.eval_s},
          {"terrain", c.rollout.terrain},
          {"seed", c.rollout.seed},
          {"spec", spec.canonical_json()}};
}

nlohmann::json run_rollout_request(const nlohmann::json& request) {
  sim::SimRolloutJob job;
  try {
    const study::StudySpec spec = study::StudySpec::from_json_text(request.at("spec").get<std::string>(), "rollout request");
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

domain::RolloutReport execute_candidate(const domain::Candidate& c, const SlotOptions& o) {
  if (auto why = domain::check_parameters(c.parameters)) return failed(c, o, "bad parameters: " + *why);
  if (auto why = check_spec(c.rollout)) return failed(c, o, "bad rollout spec: " + *why);
  // The lease bounds the rollout process's run time below: a day at most, as a study file allows.
  if (!std::isfinite(c.lease_s) || c.lease_s < 0.0 || c.lease_s > 86400.0) {
    return failed(c, o, fmt::format("bad candidate: lease_s = {} (must be in [0, 86400] s)", c.lease_s));
  }
  // The study's spec decides what this rollout computes: one this worker cannot run is refused, never
  // computed with something else (the optimizer re-issues it to a worker that can).
  SpecBook::Lookup spec;
  if (o.fake_rollout_s < 0.0) {
    spec = o.find_spec(c.spec_key);
    if (!spec.spec) return failed(c, o, "refused: " + spec.refusal, domain::Outcome::kRefused);
  }
  domain::RolloutReport r;
  const auto start = std::chrono::steady_clock::now();
  if (o.fake_rollout_s >= 0.0) {
    // Service benchmarks: a fixed delay and a smooth synthetic cost (squared distance of the
    // parameters from the middle of their ranges), so the optimizer still has something to minimise.
    std::this_thread::sleep_for(std::chrono::duration<double>(o.fake_rollout_s));
    double cost = 0.0;
    for (const auto& [name, value] : c.parameters) {
      const ParameterInfo& info = parameter_info(name);
      const double u = (value - 0.5 * (info.low + info.high)) / (info.high - info.low);
      cost += u * u;
    }
    r.outcome = domain::Outcome::kCompleted;
    r.synthetic = true;  // marked through the wire, the store and every export; never in a figure
    r.summary.cost = cost;
    r.summary.distance_m = r.summary.mean_speed_mps = 0.0;  // nothing moved: a delay, not a gait
    r.summary.normalized_torque = r.summary.summed_torque_nm = 0.0;
  } else {
    // `exec`: the shell becomes the rollout process instead of forking it, so the rollout process is the
    // worker's own child and dies with it (PR_SET_PDEATHSIG); a shell in between left it running as an
    // orphan when the worker was killed (issue 34).
    const std::string command = fmt::format("exec {} --run-one", shell_quote(self_executable()));
    const double timeout = c.lease_s > 0.0 ? c.lease_s : 600.0;
    const EvaluationOutcome outcome = run_command_objective(command, rollout_request(c, *spec.spec).dump(), timeout);
    if (!outcome.ok) return failed(c, o, outcome.message);
    if (outcome.stdout_lines.size() < 2) return failed(c, o, "rollout process printed no report");
    try {
      r = domain::report_from_json(nlohmann::json::parse(outcome.stdout_lines[outcome.stdout_lines.size() - 2]));
    } catch (const std::exception& e) {
      return failed(c, o, fmt::format("unreadable rollout output: {}", e.what()));
    }
  }
  r.id = c.id;
  r.worker_id = o.worker_id;
  r.worker_kind = domain::WorkerKind::kSimulation;
  if (r.ok()) r.error.clear();
  r.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace cpgmatch::worker
