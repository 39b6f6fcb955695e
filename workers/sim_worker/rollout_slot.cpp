#include "rollout_slot.hpp"

#include <chrono>
#include <cmath>
#include <optional>
#include <thread>

#include <fmt/format.h>

#include "cpgmatch/command_objective.hpp"
#include "cpgmatch/domain/report_json.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/sim/terrain.hpp"
#include "rollout_request.hpp"

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

// Service benchmarks: a fixed delay and a smooth synthetic cost (squared distance of the parameters from
// the middle of their ranges), so the optimizer still has something to minimise.
domain::RolloutReport fake_rollout(const domain::Candidate& c, double delay_s) {
  std::this_thread::sleep_for(std::chrono::duration<double>(delay_s));
  double cost = 0.0;
  for (const auto& [name, value] : c.parameters) {
    const ParameterInfo& info = parameter_info(name);
    const double u = (value - 0.5 * (info.low + info.high)) / (info.high - info.low);
    cost += u * u;
  }
  domain::RolloutReport r;
  r.outcome = domain::Outcome::kCompleted;
  r.synthetic = true;  // marked through the wire, the store and every export; never in a figure
  r.summary.cost = cost;
  r.summary.distance_m = r.summary.mean_speed_mps = 0.0;  // nothing moved: a delay, not a gait
  r.summary.normalized_torque = r.summary.summed_torque_nm = 0.0;
  return r;
}

std::vector<std::string> rollout_command(const SlotOptions& o) {
  if (!o.rollout_command.empty()) return o.rollout_command;
  return {self_executable(), "--serve-rollouts"};
}

}  // namespace

RolloutSlot::RolloutSlot(SlotOptions options) : options_(std::move(options)), process_(rollout_command(options_)) {}

void RolloutSlot::prepare() {
  if (options_.fake_rollout_s >= 0.0) return;
  std::string failure;
  (void)process_.ensure_running(failure);  // a failure is the next candidate's to report
}

domain::RolloutReport RolloutSlot::execute(const domain::Candidate& c) {
  const SlotOptions& o = options_;
  if (auto why = domain::check_parameters(c.parameters)) return failed(c, o, "bad parameters: " + *why);
  if (auto why = check_spec(c.rollout)) return failed(c, o, "bad rollout spec: " + *why);
  // The lease bounds the rollout's run time below: a day at most, as a study file allows.
  if (!std::isfinite(c.lease_s) || c.lease_s < 0.0 || c.lease_s > 86400.0) {
    return failed(c, o, fmt::format("bad candidate: lease_s = {} (must be in [0, 86400] s)", c.lease_s));
  }
  // The study's spec decides what this rollout computes: one this worker cannot run is refused, never
  // computed with something else (the optimizer re-issues it to a worker that can).
  SpecLookup spec;
  if (o.fake_rollout_s < 0.0) {
    spec = o.find_spec(c.spec_key);
    if (!spec.spec) return failed(c, o, "refused: " + spec.refusal, domain::Outcome::kRefused);
  }
  const auto start = std::chrono::steady_clock::now();
  domain::RolloutReport r;
  if (o.fake_rollout_s >= 0.0) {
    r = fake_rollout(c, o.fake_rollout_s);
  } else {
    std::string failure;
    std::optional<domain::RolloutReport> measured = run_in_rollout_process(c, *spec.spec, failure);
    if (!measured) return failed(c, o, failure);
    r = std::move(*measured);
  }
  r.id = c.id;
  r.worker_id = o.worker_id;
  r.worker_kind = domain::WorkerKind::kSimulation;
  if (r.ok()) r.error.clear();
  r.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

std::optional<domain::RolloutReport> RolloutSlot::run_in_rollout_process(const domain::Candidate& c,
                                                                         const study::StudySpec& spec, std::string& failure) {
  const double timeout = c.lease_s > 0.0 ? c.lease_s : 600.0;
  // The lease counts from here, a fresh process's start included, as it did for a process per rollout.
  const auto deadline = LineProcess::Clock::now() + std::chrono::duration_cast<LineProcess::Clock::duration>(
                                                         std::chrono::duration<double>(timeout));
  if (!process_.ensure_running(failure)) return std::nullopt;
  if (process_.generation() != specs_sent_to_) {  // a fresh process holds no spec yet
    specs_sent_.clear();
    specs_sent_to_ = process_.generation();
  }
  bool with_spec = !specs_sent_.count(spec.key());
  while (true) {
    const LineProcess::Reply reply = process_.exchange(rollout_request(c, spec, with_spec).dump(), deadline, timeout);
    if (!reply.ok) {
      failure = reply.failure;
      return std::nullopt;
    }
    nlohmann::json answer;
    domain::RolloutReport r;
    try {
      answer = nlohmann::json::parse(reply.line);
      if (answer.contains("unknown_spec") && !with_spec) {  // it evicted the spec since: send it again
        with_spec = true;
        continue;
      }
      if (answer.contains("error")) {
        failure = "bad rollout request: " + answer.at("error").get<std::string>();
        return std::nullopt;
      }
      r = domain::report_from_json(answer.at("report"));
      last_rollout_run_s_ = r.wall_time_s;
    } catch (const std::exception& e) {
      process_.kill_and_reap();  // its output is out of step with its requests: it cannot serve the next one
      failure = fmt::format("unreadable rollout output: {}", e.what());
      return std::nullopt;
    }
    specs_sent_.insert(spec.key());
    if (answer.value("process_ends", false)) {  // ODE failed in it (rollout_server.hpp): it is exiting
      process_.reap_ending_child(LineProcess::Clock::now() + std::chrono::seconds(2));
    }
    return r;
  }
}

}  // namespace cpgmatch::worker
