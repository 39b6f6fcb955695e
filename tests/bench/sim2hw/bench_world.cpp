#include "bench_world.hpp"

#include <chrono>
#include <fstream>
#include <numeric>

#include "cpgmatch/domain/rollout_report.hpp"
#include "cpgmatch/seeds.hpp"
#include "cpgmatch/service/study_run.hpp"
#include "cpgmatch/study/spec_rollout.hpp"

namespace cpgmatch::bench {

study::StudySpec spec_on(const std::string& model_path, const std::string& study_yaml) {
  study::SpecDefaults defaults = study::SpecDefaults::shipped();
  defaults.model_path = model_path;
  return study::StudySpec::resolve(study_yaml, "sim2hw-bench study", defaults);
}

sim::SimRolloutJob job_for(const study::StudySpec& spec, const Eigen::VectorXd& x, std::uint64_t seed) {
  const study::StudyConfig& c = spec.config();
  return study::sim_job_for(spec, c.space.to_named(x), c.terrain, seed, c.entrain_s, c.eval_s);
}

RolloutResult rollout(const study::StudySpec& spec, const Eigen::VectorXd& x, std::uint64_t seed,
                      const TraceSink& trace) {
  return sim::run_sim_rollout(job_for(spec, x, seed), trace);
}

bo::Observation observation_of(const Eigen::VectorXd& x, const RolloutResult& result) {
  return service::StudyRun::observation(x, domain::report_of(result));
}

SimulatedStudy run_simulated_study(const study::StudySpec& spec) {
  const auto start = std::chrono::steady_clock::now();
  const study::StudyConfig& c = spec.config();
  bo::BayesianOptimizer optimizer(c.space, c.optimizer);
  SimulatedStudy s;
  for (int trial = 0; trial < c.budget; ++trial) {
    const Eigen::VectorXd x = optimizer.ask(1).front();
    const bo::Observation o = observation_of(x, rollout(spec, x, study::trial_seed(spec, trial)));
    optimizer.tell_batch({o});  // as the service's model job tells one report
    s.observations.push_back(o);
  }
  const auto rec = optimizer.recommended();
  if (!rec) throw std::runtime_error("simulated study: no successful rollout, so no answer");
  s.answer = s.observations[rec->observation].x;
  s.answer_predicted = rec->predicted;
  s.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

namespace {

nlohmann::json to_json(const SimulatedStudy& s) {
  nlohmann::json obs = nlohmann::json::array();
  for (const auto& o : s.observations) {
    obs.push_back({{"x", std::vector<double>(o.x.data(), o.x.data() + o.x.size())},
                   {"y", o.y},
                   {"failed", o.failed},
                   {"fell", o.fell},
                   {"excluded", o.excluded}});
  }
  return {{"observations", obs},
          {"answer", std::vector<double>(s.answer.data(), s.answer.data() + s.answer.size())},
          {"answer_predicted", s.answer_predicted},
          {"wall_s", s.wall_s}};
}

Eigen::VectorXd vector_of(const nlohmann::json& j) {
  const auto v = j.get<std::vector<double>>();
  return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

SimulatedStudy from_json(const nlohmann::json& j) {
  SimulatedStudy s;
  for (const auto& o : j.at("observations")) {
    s.observations.push_back(bo::Observation{vector_of(o.at("x")), o.at("y").get<double>(), o.at("failed").get<bool>(),
                                             o.at("fell").get<bool>(), o.at("excluded").get<bool>()});
  }
  s.answer = vector_of(j.at("answer"));
  s.answer_predicted = j.at("answer_predicted").get<double>();
  s.wall_s = j.at("wall_s").get<double>();
  return s;
}

}  // namespace

SimulatedStudy cached_simulated_study(const study::StudySpec& spec, const std::filesystem::path& cache_dir) {
  const std::filesystem::path file = cache_dir / (spec.sha256() + ".json");
  if (std::ifstream in{file}) return from_json(nlohmann::json::parse(in));
  SimulatedStudy s = run_simulated_study(spec);
  std::filesystem::create_directories(cache_dir);
  const std::filesystem::path partial = file.string() + ".partial";
  {
    std::ofstream out{partial};
    out << to_json(s).dump() << '\n';
  }
  std::filesystem::rename(partial, file);  // a killed run never leaves half a study behind
  return s;
}

bo::Observation Robot::run(const Eigen::VectorXd& x, const TraceSink& trace) {
  last_seed_ = derived_seed(stream_, static_cast<std::uint64_t>(rollouts_));
  const bo::Observation o = observation_of(x, rollout(spec_, x, last_seed_, trace));
  ++rollouts_;
  if (o.fell) ++falls_;
  log_.push_back(o);
  return o;
}

double Evaluation::mean() const {
  return costs.empty() ? std::nan("") : std::accumulate(costs.begin(), costs.end(), 0.0) / static_cast<double>(costs.size());
}

Evaluation AnswerEvaluator::evaluate(const Eigen::VectorXd& x) {
  const std::vector<double> key(x.data(), x.data() + x.size());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (const auto it = done_.find(key); it != done_.end()) return it->second;
  }
  // Fresh seeds, far from any trial's or robot rollout's stream.
  constexpr std::uint64_t kEvaluationStream = 0xE7A1'0000'0000ULL;
  Evaluation e;
  for (int i = 0; i < seeds_; ++i) {
    const bo::Observation o = observation_of(x, rollout(spec_, x, derived_seed(kEvaluationStream, static_cast<std::uint64_t>(i))));
    // A failed rollout (a diverged simulation) says nothing about the gait: left out, as the service does.
    if (o.failed) continue;
    e.costs.push_back(o.y);
    if (o.fell) ++e.falls;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  done_.emplace(key, e);
  return e;
}

nlohmann::json to_json(const Evaluation& e) {
  return {{"mean", e.mean()}, {"costs", e.costs}, {"falls", e.falls}};
}

nlohmann::json named_json(const bo::SearchSpace& space, const Eigen::VectorXd& x) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [name, value] : space.to_named(x)) j[name] = value;
  return j;
}

}  // namespace cpgmatch::bench
