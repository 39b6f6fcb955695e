// sim2hw_bench: how much robot time each way of using it needs (issue 23's sim-to-hardware benchmark).
// Run by hand (not by ctest), driven by tests/bench/sim2hw_bench.py, which also draws the plots:
//
//   build/bin/sim2hw_bench --out DIR [--scenarios worn-knee-spring,...] [--seeds 0,1,2,3,4] [--jobs 2]
//
// For every scenario (a reality-gap model in configs/model/ standing in for the robot) and seed, five
// strategies get the same robot budget (--budget rollouts); each answer's hardware cost is then measured
// with --eval-seeds fresh noise seeds (not counted in the budget). Reference: the scenario's own optimum, the
// answer of a simulated study of the study's budget on the scenario's model. Writes DIR/cells/SCENARIO-seedS.json
// per cell (a cell already there is skipped, so an interrupted grid resumes), DIR/reference/SCENARIO.json,
// and keeps every simulated study in DIR/cache/. Progress goes to stderr.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "bench_world.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/seeds.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "strategies.hpp"

namespace fs = std::filesystem;
using namespace cpgmatch;
using namespace cpgmatch::bench;

namespace {

const std::vector<std::string> kScenarios = {"worn-knee-spring", "battery-trunk", "stiff-gearbox", "slippery-belt",
                                             "late-foottiles"};

struct Options {
  std::vector<std::string> scenarios = kScenarios;
  std::vector<int> seeds = {0, 1, 2, 3, 4};
  std::vector<int> reference_seeds = {0};
  int jobs = 1;
  int budget = 15;            // robot rollouts per strategy
  int study_budget = 150;     // simulated rollouts per study (the study default; smaller only for a smoke run)
  int eval_seeds = 5;         // fresh hardware rollouts per answer
  int simulated_per_hardware = 30;
  int calibration_rollouts = 2;
  int grid_points = 8;
  double window_s = 3.0;
  std::vector<std::string> strategies;  // empty: every strategy
  std::string hardware_keys;             // more keys of the model-based strategies' `hardware:` mapping
  std::string out;
};

std::mutex print_mutex;
const auto t0 = std::chrono::steady_clock::now();

void say(const std::string& line) {
  const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::lock_guard<std::mutex> lock(print_mutex);
  std::cerr << fmt::format("[{:6.0f} s] {}", t, line) << std::endl;
}

std::string model_path(const std::string& name) { return (fs::path(sim::config_dir()) / "model" / (name + ".yaml")).string(); }

int study_budget = 150;  // --study-budget
std::string study_yaml(int seed) { return fmt::format("name: sim2hw-bench\nseed: {}\nbudget: {}\n", seed, study_budget); }

// Runs the tasks in `jobs` processes (task i in process i % jobs), each process one task at a time.
// Processes, not threads: two ODE worlds stepped on two threads of this program at once stopped it with
// "ODE INTERNAL ERROR 1: assertion current_job->m_prev_job_next_ptr == NULL failed in ReleaseAJob()" in
// ODE's threading code. A child's results reach the parent through the files it writes (cache, cells).
// Returns false when a child failed (it said why on stderr).
bool run_in_processes(const std::vector<std::function<void()>>& tasks, int jobs) {
  if (jobs <= 1) {
    for (const auto& t : tasks) t();
    return true;
  }
  std::vector<pid_t> children;
  for (int j = 0; j < jobs; ++j) {
    const pid_t pid = fork();
    if (pid < 0) throw std::runtime_error("fork failed");
    if (pid == 0) {
      int status = 0;
      try {
        for (std::size_t i = static_cast<std::size_t>(j); i < tasks.size(); i += static_cast<std::size_t>(jobs)) tasks[i]();
      } catch (const std::exception& e) {
        say(fmt::format("error: {}", e.what()));
        status = 1;
      }
      std::_Exit(status);
    }
    children.push_back(pid);
  }
  bool ok = true;
  for (const pid_t pid : children) {
    int status = 0;
    waitpid(pid, &status, 0);
    ok = ok && WIFEXITED(status) && WEXITSTATUS(status) == 0;
  }
  return ok;
}

void write_json(const fs::path& file, const nlohmann::json& j) {
  fs::create_directories(file.parent_path());
  const fs::path partial = file.string() + ".partial";
  std::ofstream(partial) << j.dump(1) << '\n';
  fs::rename(partial, file);
}

// A scenario: its robot spec per seed is made on demand; its evaluator is shared by every cell.
struct Scenario {
  std::string name;
  study::StudySpec robot_spec;  // seed 0's: the evaluator only uses model, settings and base parameters
  std::unique_ptr<AnswerEvaluator> evaluator;
};

nlohmann::json strategy_json(const std::string& name, const StrategyRun& run, const bo::SearchSpace& space,
                             AnswerEvaluator& evaluator) {
  nlohmann::json j;
  j["name"] = name;
  j["answer"] = named_json(space, run.answer);
  j["evaluation"] = to_json(evaluator.evaluate(run.answer));
  int falls = 0;
  nlohmann::json costs = nlohmann::json::array(), fell = nlohmann::json::array(), curve = nlohmann::json::array();
  for (const auto& o : run.hardware) {
    costs.push_back(o.failed ? nlohmann::json(nullptr) : nlohmann::json(o.y));
    fell.push_back(o.fell);
    if (o.fell) ++falls;
  }
  for (const auto& x : run.answer_after) curve.push_back(evaluator.evaluate(x).mean());
  j["hardware_rollouts"] = run.hardware.size();
  j["hardware_falls"] = falls;
  j["hardware_costs"] = costs;
  j["hardware_fell"] = fell;
  j["curve"] = curve;  // hardware cost of the answer after each hardware rollout
  j["proposal_fall_probability"] = run.proposal_fall_probability;
  j["details"] = run.details;
  return j;
}

void run_cell(const Options& o, Scenario& scenario, int seed, const study::StudySpec& simulation,
              const SimulatedStudy& simulated) {
  const fs::path file = fs::path(o.out) / "cells" / fmt::format("{}-seed{}.json", scenario.name, seed);
  if (fs::exists(file)) {
    say(fmt::format("{} seed {}: already done ({})", scenario.name, seed, file.string()));
    return;
  }
  const auto start = std::chrono::steady_clock::now();
  const std::string base = study_yaml(seed);
  const study::StudySpec robot_spec = spec_on(model_path(scenario.name), base);
  // Every strategy's robot draws the same noise seeds in the same order (common random numbers).
  const std::uint64_t stream = derived_seed(0x4857'0000'0000ULL, static_cast<std::uint64_t>(seed));
  const bo::SearchSpace& space = simulation.config().space;
  nlohmann::json strategies = nlohmann::json::array();
  auto record = [&](const std::string& name, const std::function<StrategyRun(Robot&)>& strategy) {
    // --strategies: a short run of some of them (a cell then holds only those)
    if (!o.strategies.empty() && std::find(o.strategies.begin(), o.strategies.end(), name) == o.strategies.end()) return;
    const auto s0 = std::chrono::steady_clock::now();
    Robot robot(robot_spec, stream);
    const StrategyRun run = strategy(robot);
    nlohmann::json j = strategy_json(name, run, space, *scenario.evaluator);
    j["wall_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - s0).count();
    say(fmt::format("{} seed {}: {:<20} hardware cost {:.3f} ({} rollouts, {} falls), {:.0f} s", scenario.name, seed, name,
                    j["evaluation"]["mean"].get<double>(), j["hardware_rollouts"].get<int>(), j["hardware_falls"].get<int>(),
                    j["wall_s"].get<double>()));
    strategies.push_back(std::move(j));
  };
  const std::string hardware_study = fmt::format("name: sim2hw-bench\nseed: {}\nbudget: {}\nexplore_on: hardware\n", seed, o.budget);
  record("sim_optimum", [&](Robot& r) { return transferred_optimum(simulated, r); });
  record("hardware_bo", [&](Robot& r) { return hardware_only(spec_on(model_path(scenario.name), hardware_study), r); });
  // Not a study default: the default initial design (15) fills a 15-rollout budget with random points, so
  // this is hardware-only BO with a model for two thirds of its budget.
  record("hardware_bo_5_initial", [&](Robot& r) {
    return hardware_only(spec_on(model_path(scenario.name), hardware_study + "initial_points: 5\n"), r);
  });
  for (const std::string strategy : {"transfer", "multi_fidelity"}) {
    record(strategy, [&](Robot& r) {
      const study::StudySpec s =
          spec_on(model_path("morti"), base + fmt::format("hardware: {{strategy: {}, budget: {}{}{}}}\n", strategy, o.budget,
                                                          o.hardware_keys.empty() ? "" : ", ", o.hardware_keys));
      return model_over_both(s, simulated.observations, r, o.simulated_per_hardware);
    });
  }
  record("calibrate_transfer", [&](Robot& r) {
    CalibrateThenTransfer setup;
    setup.simulation = &simulation;
    setup.simulation_model_path = model_path("morti");
    setup.study_yaml = base;
    setup.hardware_budget = o.budget;
    setup.calibration_rollouts = o.calibration_rollouts;
    setup.window_s = o.window_s;
    setup.grid_points = o.grid_points;
    setup.simulated_per_hardware = o.simulated_per_hardware;
    setup.calibrated_model_file = fs::path(o.out) / "calibrated" / fmt::format("{}-seed{}.yaml", scenario.name, seed);
    setup.cache_dir = fs::path(o.out) / "cache";
    return calibrate_then_transfer(setup, simulated, r);
  });
  nlohmann::json cell = {{"scenario", scenario.name},
                         {"seed", seed},
                         {"budget", o.budget},
                         {"eval_seeds", o.eval_seeds},
                         {"simulated_per_hardware", o.simulated_per_hardware},
                         {"strategies", strategies},
                         {"wall_s", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()}};
  write_json(file, cell);
  say(fmt::format("{} seed {}: cell done in {:.0f} s -> {}", scenario.name, seed, cell["wall_s"].get<double>(), file.string()));
}

int run(const Options& o) {
  const fs::path out(o.out);
  const fs::path cache = out / "cache";
  for (const auto& name : o.scenarios) {
    if (!fs::exists(model_path(name))) throw InputError(fmt::format("--scenarios: no model file {}", model_path(name)));
  }
  std::map<std::string, Scenario> scenarios;
  for (const auto& name : o.scenarios) {
    Scenario s{name, spec_on(model_path(name), study_yaml(0)), nullptr};
    s.evaluator = std::make_unique<AnswerEvaluator>(s.robot_spec, o.eval_seeds);
    scenarios.emplace(name, std::move(s));
  }
  // Phase 1: the simulated studies every cell needs (morti.yaml per seed) and the references.
  std::map<int, std::unique_ptr<study::StudySpec>> simulation;
  std::map<int, SimulatedStudy> simulated;
  std::vector<std::function<void()>> tasks;
  for (const int seed : o.seeds) {
    simulation[seed] = std::make_unique<study::StudySpec>(spec_on(model_path("morti"), study_yaml(seed)));
    tasks.push_back([&, seed] {
      say(fmt::format("simulated study on morti, seed {} ...", seed));
      SimulatedStudy s = cached_simulated_study(*simulation.at(seed), cache);
      say(fmt::format("simulated study on morti, seed {}: answer predicted {:.3f}", seed, s.answer_predicted));
      simulated.emplace(seed, std::move(s));
    });
  }
  std::map<std::string, nlohmann::json> references;
  for (const auto& name : o.scenarios) {
    for (const int seed : o.reference_seeds) {
      tasks.push_back([&, name, seed] {
        say(fmt::format("reference: simulated study on {}, seed {} ...", name, seed));
        Scenario& s = scenarios.at(name);
        const study::StudySpec spec = spec_on(model_path(name), study_yaml(seed));
        const SimulatedStudy study = cached_simulated_study(spec, cache);
        const Evaluation e = s.evaluator->evaluate(study.answer);
        say(fmt::format("reference: {} seed {}: hardware cost {:.3f} ({} falls)", name, seed, e.mean(), e.falls));
        references[name]["studies"].push_back({{"seed", seed},
                                               {"answer", named_json(spec.config().space, study.answer)},
                                               {"predicted", study.answer_predicted},
                                               {"evaluation", to_json(e)}});
      });
    }
  }
  // The studies in parallel processes (each writes its cache file), then read back here from the cache.
  if (!run_in_processes(tasks, o.jobs)) throw std::runtime_error("a simulated study failed (see above)");
  run_in_processes(tasks, 1);
  for (auto& [name, ref] : references) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& s : ref["studies"]) best = std::min(best, s["evaluation"]["mean"].get<double>());
    ref["scenario"] = name;
    ref["cost"] = best;  // the best evaluated answer of the reference studies
    ref["eval_seeds"] = o.eval_seeds;
    write_json(out / "reference" / (name + ".json"), ref);
  }
  // Phase 2: the cells, seed by seed, so a grid cut short has every scenario at its first seeds.
  tasks.clear();
  for (const int seed : o.seeds) {
    for (const auto& name : o.scenarios) {
      tasks.push_back([&, name, seed] { run_cell(o, scenarios.at(name), seed, *simulation.at(seed), simulated.at(seed)); });
    }
  }
  if (!run_in_processes(tasks, o.jobs)) throw std::runtime_error("a cell failed (see above)");
  say("done");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"sim2hw_bench: robot rollouts and hardware cost of five ways to use a robot (issue 23)"};
  Options o;
  app.add_option("--out", o.out, "results directory (cells/, reference/, cache/, calibrated/)")->required();
  app.add_option("--scenarios", o.scenarios, "reality-gap models (configs/model/NAME.yaml)")->delimiter(',')->capture_default_str();
  app.add_option("--seeds", o.seeds, "study seeds")->delimiter(',')->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--reference-seeds", o.reference_seeds, "seeds of the reference studies (the best answer counts)")
      ->delimiter(',')->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--jobs", o.jobs, "cells and studies at once processes (CPU is shared: at most 2)")->check(CLI::Range(1, 2))->capture_default_str();
  app.add_option("--budget", o.budget, "robot rollouts per strategy")->check(CLI::Range(2, 100))->capture_default_str();
  app.add_option("--eval-seeds", o.eval_seeds, "fresh robot rollouts per answer (not counted)")->check(CLI::Range(1, 50))->capture_default_str();
  app.add_option("--simulated-per-hardware", o.simulated_per_hardware,
                 "simulated results told to the hardware model per robot rollout")->check(CLI::Range(0, 1000))->capture_default_str();
  app.add_option("--calibration-rollouts", o.calibration_rollouts, "robot rollouts traced for calibration")
      ->check(CLI::Range(1, 10))->capture_default_str();
  app.add_option("--grid", o.grid_points, "calibration grid points per value (docs/calibration.md)")->check(CLI::Range(0, 50))->capture_default_str();
  app.add_option("--window", o.window_s, "seconds of each trace fitted")->check(CLI::Range(1.5, 20.0))->capture_default_str();
  app.add_option("--strategies", o.strategies,
                 "only these strategies (sim_optimum, hardware_bo, hardware_bo_5_initial, transfer, multi_fidelity, "
                 "calibrate_transfer; default: all)")
      ->delimiter(',')
      ->check(CLI::IsMember({"sim_optimum", "hardware_bo", "hardware_bo_5_initial", "transfer", "multi_fidelity",
                             "calibrate_transfer"}));
  app.add_option("--hardware-keys", o.hardware_keys,
                 "more keys for transfer and multi_fidelity's hardware: mapping, e.g. \"start_after: 150, safe_margin: 0.2\"");
  app.add_option("--study-budget", study_budget, "simulated rollouts per study (150, the default; less only to try the program)")
      ->check(CLI::Range(20, 1000))->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (o.calibration_rollouts >= o.budget) {
    std::cerr << "--calibration-rollouts: must be below --budget\n";
    return 2;
  }
  try {
    return run(o);
  } catch (const InputError& e) {
    std::cerr << "error: " << e.what() << '\n';
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << '\n';
    return 1;
  }
}
