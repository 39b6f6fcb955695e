#include "strategies.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "cpgmatch/bo/hardware_optimizer.hpp"
#include "cpgmatch/calibration/calibrated_model.hpp"
#include "cpgmatch/calibration/calibration.hpp"
#include "cpgmatch/calibration/measured_trace.hpp"
#include "cpgmatch/service/study_run.hpp"

namespace cpgmatch::bench {

StrategyRun transferred_optimum(const SimulatedStudy& simulation, Robot& robot) {
  StrategyRun run;
  run.answer = simulation.answer;
  run.hardware.push_back(robot.run(simulation.answer));
  run.answer_after.push_back(simulation.answer);
  run.details["simulation_predicted"] = simulation.answer_predicted;
  return run;
}

StrategyRun hardware_only(const study::StudySpec& hardware_study, Robot& robot) {
  const study::StudyConfig& c = hardware_study.config();
  bo::BayesianOptimizer optimizer(c.space, c.optimizer);
  StrategyRun run;
  for (int trial = 0; trial < c.budget; ++trial) {
    const Eigen::VectorXd x = optimizer.ask(1).front();
    const bo::Observation o = robot.run(x);
    optimizer.tell_batch({o});
    run.hardware.push_back(o);
    const auto rec = optimizer.recommended();
    // Before the first rollout that did not fail there is no answer: the first point stands in.
    run.answer_after.push_back(rec ? optimizer.observations()[rec->observation].x : x);
  }
  run.answer = run.answer_after.back();
  run.details["initial_points"] = c.optimizer.initial_points;
  return run;
}

StrategyRun model_over_both(const study::StudySpec& study, const std::vector<bo::Observation>& simulated, Robot& robot,
                            int simulated_per_hardware, const std::vector<bo::Observation>& already) {
  const study::StudyConfig& c = study.config();
  if (!c.hardware.models_hardware()) throw std::logic_error("model_over_both: the study has no transfer or multi_fidelity");
  // The options the coordinator gives a study's hardware model.
  bo::HardwareOptimizer model(c.space, service::hardware_model_options(c));
  StrategyRun run;
  std::size_t told_simulated = 0;
  auto tell_simulated_up_to = [&](std::size_t n) {
    for (n = std::min(n, simulated.size()); told_simulated < n; ++told_simulated) model.tell_simulation(simulated[told_simulated]);
  };
  auto answer = [&] {
    const auto rec = model.recommended();
    return rec ? model.hardware_observations()[rec->observation].x : Eigen::VectorXd();
  };
  // Each step is one HardwareModelJob of kind kAsk as the coordinator runs it once the robot is free again:
  // tell the simulated results and the hardware report that came in since the last job, ask (which fits),
  // then the snapshot's answer from that same fit.
  std::vector<bo::Observation> untold_hardware = already;
  for (int j = 0; j < c.hardware.budget; ++j) {
    tell_simulated_up_to(static_cast<std::size_t>(c.hardware.start_after) +
                         static_cast<std::size_t>(j) * static_cast<std::size_t>(simulated_per_hardware));
    for (const auto& o : untold_hardware) model.tell_hardware(o);
    const bool reported_since_last_job = j > 0;
    untold_hardware.clear();
    const bo::HardwareProposal p = model.ask({});
    if (reported_since_last_job) run.answer_after.push_back(answer());
    run.proposal_fall_probability.push_back(p.fall_probability);
    // Issue 33's safe exploration, per proposal: where it came from and the bound it was checked against.
    run.details["proposal_basis"].push_back(bo::to_string(p.basis));
    run.details["proposal_cost_bound"].push_back(p.cost_bound);
    run.details["proposal_cost_limit"].push_back(std::isfinite(p.cost_limit) ? nlohmann::json(p.cost_limit) : nlohmann::json());
    if (j == 0) {
      // The first robot rollout should be the transferred simulated optimum: the best simulated observation
      // that walked among those told, and whether it is the simulated study's own answer too.
      if (const auto start = model.start_point()) {
        const Eigen::VectorXd& best = model.simulation_observations()[start->observation].x;
        run.details["first_is_best_simulated"] = p.x == best;
        run.details["best_simulated_cost"] = model.simulation_observations()[start->observation].y;
      }
    }
    const bo::Observation o = robot.run(p.x);
    run.hardware.push_back(o);
    untold_hardware.push_back(o);
  }
  // The last job (kTell): every remaining simulated result and the last hardware report.
  tell_simulated_up_to(simulated.size());
  for (const auto& o : untold_hardware) model.tell_hardware(o);
  run.answer = answer();
  run.answer_after.push_back(run.answer);
  if (const auto* mf = model.multi_fidelity_model()) {
    run.details["rho"] = mf->rho();
    run.details["constant_discrepancy"] = mf->constant_discrepancy();
  }
  run.details["simulated_told"] = told_simulated;
  return run;
}

namespace {

std::string file_text(const std::string& path) {
  std::ifstream in{path};
  if (!in) throw std::runtime_error(fmt::format("cannot read {}", path));
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The values calibration can fit that the scenario changes: a lab would fit what it suspects; the
// benchmark fits what it knows differs (the values' true sizes stay unknown to the fit).
std::vector<const calibration::ModelValue*> values_that_differ(const sim::PlanarLegModel& simulation,
                                                                const sim::PlanarLegModel& robot) {
  std::vector<const calibration::ModelValue*> values;
  for (const auto& v : calibration::calibratable_values()) {
    if (v.get(simulation) != v.get(robot)) values.push_back(&v);
  }
  return values;
}

}  // namespace

StrategyRun calibrate_then_transfer(const CalibrateThenTransfer& setup, const SimulatedStudy& simulation,
                                    Robot& robot) {
  const study::StudySpec& sim_spec = *setup.simulation;
  // The robot first runs the simulated optimum, the lab's best guess, and keeps what it measured.
  std::vector<calibration::CalibrationTrace> traces;
  std::vector<std::string> sources;
  std::vector<bo::Observation> calibration_rollouts;
  std::vector<Eigen::VectorXd> answers_meanwhile;
  nlohmann::json details = nlohmann::json::object();
  for (int i = 0; i < setup.calibration_rollouts; ++i) {
    calibration::MeasuredTrace measured;
    const bo::Observation o = robot.run(simulation.answer, calibration::record_trace(measured));
    measured.source = fmt::format("robot rollout {} (seed {})", i + 1, robot.last_seed());
    calibration_rollouts.push_back(o);
    answers_meanwhile.push_back(simulation.answer);
    const sim::SimRolloutJob made_with = job_for(sim_spec, simulation.answer, robot.last_seed());
    try {
      // The replay's own contact-sensor noise is not the robot's: another seed.
      traces.push_back(calibration::prepare_trace(std::move(measured), made_with.params, made_with.settings,
                                                  made_with.terrain, robot.last_seed() + 1, setup.window_s));
      sources.push_back(traces.back().measured.source);
    } catch (const std::exception& e) {
      details["unusable_traces"].push_back(e.what());  // e.g. a fall before the window ends
    }
  }
  const std::vector<const calibration::ModelValue*> values = values_that_differ(sim_spec.model(), robot.spec().model());
  std::string study_model_path = setup.simulation_model_path;
  if (!traces.empty() && !values.empty()) {
    calibration::CalibrationOptions options;
    options.values = values;
    options.grid_points = setup.grid_points;
    calibration::Calibration fit(sim_spec.model(), std::move(traces), options);
    const calibration::CalibrationResult r = fit.solve();
    nlohmann::json fitted = nlohmann::json::array();
    for (std::size_t i = 0; i < r.values.size(); ++i) {
      const double truth = values[i]->get(robot.spec().model());
      fitted.push_back({{"name", r.values[i].name},
                        {"unit", r.values[i].unit},
                        {"start", r.values[i].initial},
                        {"truth", truth},
                        {"estimate", r.values[i].estimate},
                        {"sd", r.values[i].standard_deviation},
                        {"relative_error", (r.values[i].estimate - truth) / truth},
                        {"at_bound", r.values[i].at_bound},
                        {"sd_from", r.values[i].sd_from},
                        {"identifiable", r.values[i].identifiable},
                        {"not_identifiable_reason", r.values[i].not_identifiable_reason}});
    }
    details["calibration"] = {{"values", fitted},
                              {"cost_before", r.cost_before},
                              {"cost_after", r.cost_after},
                              {"residuals", r.residual_count},
                              {"iterations", r.iterations},
                              {"replays", r.simulations},
                              {"converged", r.converged},
                              {"wall_s", r.wall_time_s}};
    std::filesystem::create_directories(setup.calibrated_model_file.parent_path());
    std::ofstream(setup.calibrated_model_file)
        << calibration::calibrated_model_text(file_text(setup.simulation_model_path), setup.simulation_model_path, r,
                                              sources);
    study_model_path = setup.calibrated_model_file.string();
  } else {
    details["calibration"] = nullptr;  // nothing to fit with: the study runs on the uncalibrated model
  }
  // A simulated study on the calibrated model, then `transfer` with the rest of the budget.
  const study::StudySpec calibrated = spec_on(study_model_path, setup.study_yaml);
  const SimulatedStudy calibrated_study = cached_simulated_study(calibrated, setup.cache_dir);
  const int rest = setup.hardware_budget - setup.calibration_rollouts;
  StrategyRun run;
  if (rest > 0) {
    const study::StudySpec transfer =
        spec_on(study_model_path, setup.study_yaml + fmt::format("hardware: {{strategy: transfer, budget: {}}}\n", rest));
    run = model_over_both(transfer, calibrated_study.observations, robot, setup.simulated_per_hardware,
                          calibration_rollouts);
  } else {
    run.answer = calibrated_study.answer;  // no robot rollout left: the calibrated optimum transferred
    run.answer_after.push_back(run.answer);
  }
  run.hardware.insert(run.hardware.begin(), calibration_rollouts.begin(), calibration_rollouts.end());
  run.answer_after.insert(run.answer_after.begin(), answers_meanwhile.begin(), answers_meanwhile.end());
  run.details.update(details);
  run.details["calibrated_study_answer"] = named_json(sim_spec.config().space, calibrated_study.answer);
  return run;
}

}  // namespace cpgmatch::bench
