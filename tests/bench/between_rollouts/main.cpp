// bench_between_rollouts [N [ENTRAIN_S EVAL_S [SIM_WORKER]]]: the time from a slot getting a candidate to
// having its report, minus the rollout's own run time (as the rollout process measured it), median of N,
// for a fresh process per rollout (before) and for the slot's kept process (after), one of each in turn on
// the same candidates. The kept process's first rollout (it starts the process and parses the spec) is
// reported apart, and what the kept process does besides the rollout is timed again in this process (job,
// world, report JSON; the rest is pipes and both sides' request and report parsing). Also checks that both paths report the same bits (but the wall time).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cpgmatch/command_objective.hpp"
#include "cpgmatch/domain/report_json.hpp"
#include "rollout_request.hpp"
#include "rollout_slot.hpp"

using namespace cpgmatch;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string without_wall_time(domain::RolloutReport r) {
  r.wall_time_s = 0.0;
  return domain::to_json(r).dump();
}

struct Timed {
  double overhead_s = 0.0;
  std::string report;
};

// The path before kept processes, as RolloutSlot ran it: the request with its spec to `exec W --run-one`.
Timed fresh_process(const domain::Candidate& c, const study::StudySpec& spec, const std::string& worker) {
  const auto start = Clock::now();
  const EvaluationOutcome out = run_command_objective(fmt::format("exec {} --run-one", shell_quote(worker)),
                                                      worker::rollout_request(c, spec).dump(), c.lease_s);
  if (!out.ok || out.stdout_lines.size() < 2) throw std::runtime_error("fresh process: " + out.message);
  domain::RolloutReport r = domain::report_from_json(nlohmann::json::parse(out.stdout_lines[out.stdout_lines.size() - 2]));
  const double total = seconds_since(start);
  const double rollout = r.wall_time_s;
  r.id = c.id;
  r.worker_id = "bench";
  r.worker_kind = domain::WorkerKind::kSimulation;
  return {total - rollout, without_wall_time(r)};
}

// What the rollout process does besides the rollout, here in this process: build the job and the ODE world,
// and write the report as JSON (no pipes, no request parsing).
double in_this_process(const domain::Candidate& c, const study::StudySpec& spec) {
  const nlohmann::json request = worker::rollout_request(c, spec, false);
  const auto start = Clock::now();
  const nlohmann::json report = worker::run_rollout(spec, request);
  const std::string line = report.dump();
  return seconds_since(start) - report.at("wall_time_s").get<double>();
}

Timed kept_process(const domain::Candidate& c, worker::RolloutSlot& slot) {
  const auto start = Clock::now();
  const domain::RolloutReport r = slot.execute(c);
  const double total = seconds_since(start);
  if (!r.ok()) throw std::runtime_error("kept process: " + r.error);
  return {total - slot.last_rollout_run_s(), without_wall_time(r)};
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::stoi(argv[1]) : 20;
  const double entrain_s = argc > 3 ? std::stod(argv[2]) : 0.5;
  const double eval_s = argc > 3 ? std::stod(argv[3]) : 0.5;
  std::string worker = argc > 4 ? argv[4] : "";
  if (worker.empty()) {
    const std::string self = self_executable();
    worker = self.substr(0, self.rfind('/') + 1) + "cpgmatch-sim-worker";
  }
  const auto spec = std::make_shared<const study::StudySpec>(
      study::StudySpec::resolve("name: between-rollouts\n", "bench.yaml", study::SpecDefaults::shipped()));
  worker::SlotOptions options;
  options.worker_id = "bench";
  options.rollout_command = {worker, "--serve-rollouts"};
  options.find_spec = [spec](std::uint64_t) { return worker::SpecLookup{spec, ""}; };
  worker::RolloutSlot slot(options);

  const auto candidate = [&](int i) {
    domain::Candidate c;
    c.id = domain::AttemptId{1, 1, i, 0};
    c.worker_id = "bench";
    c.lease_s = 120.0;
    c.spec_key = spec->key();
    c.rollout = {entrain_s, eval_s, "flat", 1000u + static_cast<std::uint64_t>(i)};
    c.parameters = {{"hip_offset", -0.1934}, {"hip_amplitude", 0.3454}, {"knee_amplitude", 0.5236},
                    {"frequency", 1.0 + 0.01 * i}, {"duty_factor_front", 0.3}, {"duty_factor_hind", 0.75},
                    {"knee_phase_shift", 0.0}, {"overswing", 0.5}};
    return c;
  };
  const Timed first = kept_process(candidate(-1), slot);  // starts the kept process, which parses the spec
  std::vector<double> before, after, inside;
  int differ = 0;
  for (int i = 0; i < n; ++i) {
    const domain::Candidate c = candidate(i);
    const Timed a = fresh_process(c, *spec, worker);
    const Timed b = kept_process(c, slot);
    before.push_back(a.overhead_s);
    after.push_back(b.overhead_s);
    differ += a.report != b.report;
    inside.push_back(in_this_process(c, *spec));
  }
  const auto ms = [](double s) { return 1000.0 * s; };
  std::printf("rollouts of %.2f + %.2f s, %d of each, alternating; time in the slot minus the rollout's own run time:\n",
              entrain_s, eval_s, n);
  std::printf("  fresh process per rollout (--run-one): median %.2f ms (min %.2f, max %.2f)\n", ms(median(before)),
              ms(*std::min_element(before.begin(), before.end())), ms(*std::max_element(before.begin(), before.end())));
  std::printf("  kept process (--serve-rollouts):       median %.2f ms (min %.2f, max %.2f); its first rollout %.2f ms\n",
              ms(median(after)), ms(*std::min_element(after.begin(), after.end())),
              ms(*std::max_element(after.begin(), after.end())), ms(first.overhead_s));
  std::printf("  of which the rollout process's own work (job, ODE world, report JSON), timed in this process: median %.2f ms\n",
              ms(median(inside)));
  std::printf("  reports that differ between the two paths (but the wall time): %d of %d\n", differ, n);
  return differ == 0 ? 0 : 1;
}
