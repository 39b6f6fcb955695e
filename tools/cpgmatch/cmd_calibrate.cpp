// `cpgmatch calibrate`: fits model values to measured rollout traces (services/calibration) and writes the
// calibrated model. The traces come from CSV files (`cpgmatch rollout --trace`, or a robot's) or from a
// study's store (`--store PATH --study ID`: the hardware rollouts the robot agent sent, study_traces.hpp). A
// study of a robot (`robot:`) is fitted on its description and written as a robot folder (calibrated_robot.hpp).
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "cpgmatch/calibration/calibrated_model.hpp"
#include "cpgmatch/calibration/calibrated_robot.hpp"
#include "cpgmatch/calibration/robot_values.hpp"
#include "cpgmatch/calibration/calibration.hpp"
#include "cpgmatch/calibration/study_traces.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/yaml_reader.hpp"
#include "flag_checks.hpp"

namespace cpgmatch::cli {
namespace {

namespace cal = cpgmatch::calibration;

struct CalibrateOptions {
  std::vector<std::string> traces;
  std::string store;
  int study_id = 0;
  std::string params_file;
  // a.b,c.d. Default: the knee spring and the trunk mass, which a gait's traces tell apart (docs/calibration.md).
  std::string values = "knee_spring.stiffness_nm_per_rad,trunk.mass_kg";
  std::string out;
  std::string model_file;
  std::string settings_file;
  std::string terrain = "flat";
  double treadmill_mps = 0.0;
  std::uint64_t seed = 0;
  double window_s = 1.0;
  int windows = 3;
  double contact_weight = 1.0;
  double force_scale = 2.0;
  double robust_rms = 3.0;
  double relative_step = 0.02;
  int max_iterations = 25;
  int grid_points = 0;
  std::vector<double> scan;
  bool json = false;
};

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("--model {}: cannot open", path));
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

nlohmann::json rms_json(const cal::ChannelRms& r) {
  return {{"knee_rad", r.knee_rad}, {"hip_rad", r.hip_rad}, {"pitch_rad", r.pitch_rad}, {"speed_mps", r.speed_mps},
          {"contact_mismatch", r.contact_mismatch}, {"foot_force_n", r.foot_force_n}};
}

nlohmann::json finite_or_null(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

nlohmann::json result_json(const cal::CalibrationResult& r, const std::string& out) {
  nlohmann::json values = nlohmann::json::array();
  for (const auto& v : r.values) {
    values.push_back({{"name", v.name}, {"unit", v.unit}, {"initial", v.initial}, {"estimate", v.estimate},
                      {"standard_deviation", std::isfinite(v.standard_deviation) ? nlohmann::json(v.standard_deviation)
                                                                                 : nlohmann::json(nullptr)},
                      {"lower", v.lower}, {"upper", v.upper}, {"at_bound", v.at_bound},
                      {"covariance_sd", finite_or_null(v.covariance_sd)}, {"window_sd", finite_or_null(v.window_sd)},
                      {"window_se", finite_or_null(v.window_se)}, {"window_estimates", v.window_estimates},
                      {"sd_from", v.sd_from}, {"identifiable", v.identifiable},
                      {"not_identifiable_reason", v.not_identifiable_reason}});
  }
  return {{"values", values}, {"cost_before", r.cost_before}, {"cost_after", r.cost_after},
          {"rms_before", rms_json(r.rms_before)}, {"rms_after", rms_json(r.rms_after)},
          {"residuals", r.residual_count}, {"windows", r.window_count}, {"iterations", r.iterations}, {"replays", r.simulations},
          {"solver_start", r.solver_start}, {"wall_time_s", r.wall_time_s}, {"converged", r.converged}, {"solver", r.solver_report}, {"out", out}};
}

void print_result(const cal::CalibrationResult& r, const std::string& out) {
  fmt::print("calibrated {} value(s) in {:.1f} s ({} iterations, {} replays, {} residuals): {}\n", r.values.size(),
             r.wall_time_s, r.iterations, r.simulations, r.residual_count, r.solver_report);
  for (const auto& v : r.values) {
    fmt::print("  {:<42} {:>10.5g} -> {:>10.5g} +- {:.3g} {}{}\n", v.name, v.initial, v.estimate, v.standard_deviation,
               v.unit, v.at_bound ? "  (at its physical bound)" : "");
    // Both measures, so that a reader sees how far the noise alone would have put it.
    if (v.window_estimates.size() < 2) {
      fmt::print("      sd: the covariance alone (no windows to compare: a lower bound)\n");
    } else {
      fmt::print("      sd: covariance {:.3g}, {} windows' spread {:.3g} (standard error {:.3g}); the sd is the {}\n",
                 v.covariance_sd, v.window_estimates.size(), v.window_sd, v.window_se,
                 v.sd_from == "windows" ? "windows' spread (larger)" : "covariance's (larger)");
    }
    if (!v.identifiable) fmt::print("      NOT IDENTIFIABLE: {}\n", v.not_identifiable_reason);
  }
  fmt::print("  cost {:.6g} -> {:.6g}; RMS knee {:.4f} -> {:.4f} rad, hip {:.4f} -> {:.4f} rad, speed {:.3f} -> "
             "{:.3f} m/s, contact mismatch {:.1f}% -> {:.1f}%, foot force {:.2f} -> {:.2f} N\n",
             r.cost_before, r.cost_after, r.rms_before.knee_rad, r.rms_after.knee_rad, r.rms_before.hip_rad,
             r.rms_after.hip_rad, r.rms_before.speed_mps, r.rms_after.speed_mps, 100 * r.rms_before.contact_mismatch,
             100 * r.rms_after.contact_mismatch, r.rms_before.foot_force_n, r.rms_after.foot_force_n);
  fmt::print("  wrote {}\n", out);
}

// The cost along each fitted value's axis through the start model (the others held): is the objective
// smooth enough near the answer for a gradient method?
void print_scan(cal::Calibration& calibration, const sim::PlanarLegModel& start, const std::vector<const cal::ModelValue*>& values,
                const std::vector<double>& factors) {
  std::vector<double> x0;
  for (const auto* v : values) x0.push_back(v->get(start));
  for (std::size_t i = 0; i < values.size(); ++i) {
    fmt::print("scan {} (start {:.5g} {}):\n", values[i]->name, x0[i], values[i]->unit);
    for (double f : factors) {
      std::vector<double> x = x0;
      x[i] = x0[i] * f;
      fmt::print("  x{:<6.3f} {:>10.5g}  cost {:.6g}\n", f, x[i], calibration.cost_at(x));
    }
  }
}

}  // namespace

void add_calibrate_command(CLI::App& app) {
  auto o = std::make_shared<CalibrateOptions>();
  CLI::App* cmd = app.add_subcommand("calibrate", "fit model values to measured rollout traces (Ceres)");
  cmd->add_option("--trace", o->traces, "a rollout trace CSV (`cpgmatch rollout --trace`), repeatable");
  cmd->add_option("--store", o->store, "a study store: fit the hardware traces the robot agent sent (with --study)");
  cmd->add_option("--study", o->study_id, "with --store: the study whose traces are fitted")->check(CLI::Range(1, 1 << 30));
  cmd->add_option("--params-file", o->params_file, "with --trace: the CPG parameters the traces were made with (YAML)");
  cmd->add_option("--params", o->values,
                  "model values to fit, comma-separated (a robot study's default: its knee spring and trunk mass)")
      ->capture_default_str();
  cmd->add_option("--out", o->out, "where to write the calibrated model YAML (a robot study: the calibrated robot's folder)")
      ->required();
  cmd->add_option("--model", o->model_file, "start model YAML (default: configs/model/morti.yaml; with --store: the study's)");
  cmd->add_option("--settings", o->settings_file, "with --trace: rollout settings the traces were made with (default: configs/rollout.yaml)");
  cmd->add_option("--terrain", o->terrain, "the ground the traces were made on: flat | step:H@D | rough:A | shift:H@T");
  cmd->add_option("--treadmill", o->treadmill_mps, "treadmill belt speed of the traces, m/s")->check(finite_in(-5.0, 5.0, "m/s"));
  cmd->add_option("--seed", o->seed, "seed of the replays' contact-sensor noise")->check(whole_non_negative());
  // A replay drifts from the robot as contact events accumulate: a few seconds from the start fit best.
  cmd->add_option("--window", o->window_s, "seconds of each window (the fit uses --windows of them from each trace's start)")
      ->check(finite_in(0.1, 60.0, "s"));
  // Each window is fitted alone too: how far their answers disagree is the sd a model error shows.
  cmd->add_option("--windows", o->windows, "windows per trace, consecutive from its start (the fit's span: window x windows)")
      ->check(CLI::Range(1, 60));
  cmd->add_option("--contact-weight", o->contact_weight, "weight of a tick's contact mismatch (0: contacts left out)")
      ->check(finite_in(0.0, 100.0, ""));
  cmd->add_option("--force-scale", o->force_scale, "foot-force misfit counted as one unit, N (0: forces left out)")
      ->check(finite_in(0.0, 1000.0, "N"));
  cmd->add_option("--robust-rms", o->robust_rms, "Huber threshold: a tick's residual RMS, in scales")->check(finite_in(0.1, 1000.0, ""));
  cmd->add_option("--relative-step", o->relative_step, "central-difference step relative to each value")
      ->check(finite_in(1e-4, 0.2, ""));
  cmd->add_option("--max-iterations", o->max_iterations, "solver iterations at most")->check(CLI::Range(1, 500));
  cmd->add_option("--grid", o->grid_points, "first try this many points across each value's physical range (0: none)")
      ->check(CLI::Range(0, 100));
  cmd->add_option("--scan", o->scan, "before fitting, print the cost at these multiples of each start value")
      ->check(finite_in(0.01, 100.0, ""));
  cmd->add_flag("--json", o->json, "print exactly one JSON object");
  cmd->callback([o, cmd] {
    const auto value_list = [&](const std::string& names) {
      try {
        return cal::parse_model_value_list(names);
      } catch (const InputError& e) {
        throw InputError(fmt::format("--params: {}", e.what()));
      }
    };
    std::vector<const cal::ModelValue*> values = value_list(o->values);
    struct Source {
      std::string model_text, model_name;
      sim::PlanarLegModel start;
      std::optional<RobotDescription> robot;  // a robot study's: --out is then a robot folder
      std::vector<cal::CalibrationTrace> traces;
      std::vector<std::string> names;
    } source;
    if (o->store.empty() == o->traces.empty()) throw InputError("give either --trace FILE ... or --store PATH --study ID");
    if (o->store.empty()) {
      if (o->params_file.empty()) throw InputError("--params-file: required with --trace");
      if (o->study_id != 0) throw InputError("--study: only with --store");
      source.model_name = o->model_file.empty() ? sim::default_model_path() : o->model_file;
      source.model_text = read_text(source.model_name);
      source.start = sim::parse_model_file(YamlReader::from_string(source.model_text, source.model_name));
      const CpgParameters params = load_parameters(o->params_file);
      const RolloutSettings settings =
          load_rollout_settings(o->settings_file.empty() ? sim::default_rollout_settings_path() : o->settings_file);
      sim::TerrainSpec terrain = sim::TerrainSpec::parse(o->terrain);
      terrain.treadmill_speed_mps = o->treadmill_mps;
      for (const auto& path : o->traces) {
        source.traces.push_back(cal::prepare_trace(cal::read_trace_csv(path), params, settings, terrain, o->seed, o->window_s * o->windows));
      }
      source.names = o->traces;
    } else {
      // Each trace brings its own parameters, rate, seed and terrain; the study's spec the rest.
      if (o->study_id == 0) throw InputError("--study: required with --store");
      for (const char* flag : {"--params-file", "--settings", "--terrain", "--treadmill", "--seed"}) {
        if (cmd->count(flag) > 0) throw InputError(fmt::format("{}: not with --store (each stored trace says it)", flag));
      }
      if (!std::filesystem::exists(o->store)) throw InputError(fmt::format("--store {}: no such file", o->store));
      const study::StudyStore store(o->store, study::kReadOnly);
      cal::StudyTraces st = cal::load_study_traces(store, o->study_id, o->window_s * o->windows);
      for (const auto& why : st.skipped) {
        if (!o->json) fmt::print("skipped {}\n", why);
      }
      source.model_name = st.model_source;
      source.model_text = st.model_yaml;
      source.start = st.model;
      source.robot = st.robot;
      if (!o->model_file.empty() && source.robot) {
        throw InputError(fmt::format("--model: the study is of robot '{}', whose description is the start; to start "
                                     "elsewhere, edit a copy of the robot's folder and study that",
                                     source.robot->name));
      }
      if (!o->model_file.empty()) {  // another start than the study's own model
        source.model_name = o->model_file;
        source.model_text = read_text(o->model_file);
        source.start = sim::parse_model_file(YamlReader::from_string(source.model_text, o->model_file));
      }
      source.traces = std::move(st.traces);
      source.names = std::move(st.sources);
    }
    // A robot's values, with their places in its description checked and bounds of its own (robot_values.hpp);
    // a model file's, only those a model file has.
    std::vector<cal::ModelValue> robot_values;
    if (source.robot) {
      if (cmd->count("--params") == 0) values = value_list(cal::default_robot_value_list(*source.robot));
      try {
        robot_values = cal::robot_model_values(values, *source.robot, source.start);
      } catch (const InputError& e) {
        throw InputError(fmt::format("--params: {}", e.what()));
      }
      values.clear();
      for (const cal::ModelValue& v : robot_values) values.push_back(&v);
    } else {
      for (const cal::ModelValue* v : values) {
        if (!v->in_model_files) {
          throw InputError(fmt::format("--params: {} is a value of a robot's description, which a model file has not; "
                                       "calibrate it with --store PATH --study ID of a study of the robot",
                                       v->name));
        }
      }
    }
    const sim::PlanarLegModel& start = source.start;
    cal::CalibrationOptions options;
    options.values = values;
    options.scales.contact_mismatch = o->contact_weight;
    options.scales.foot_force_n = o->force_scale;
    options.robust_rms = o->robust_rms;
    options.relative_step = o->relative_step;
    options.max_iterations = o->max_iterations;
    options.grid_points = o->grid_points;
    options.windows_per_trace = static_cast<std::size_t>(o->windows);
    cal::Calibration calibration(start, std::move(source.traces), options);
    if (!o->scan.empty() && !o->json) print_scan(calibration, start, values, o->scan);
    const cal::CalibrationResult result = calibration.solve();
    std::string written = o->out;
    if (source.robot) {
      // A robot folder: robot.yaml and its URDF with the fitted values in place, loaded back by the loader.
      const cal::CalibratedRobot files = cal::calibrated_robot(*source.robot, source.model_name, result, source.names);
      cal::write_calibrated_robot(o->out, files);
      written = fmt::format("{0}/robot.yaml and {0}/{1} (robot '{2}'; `cpgmatch robot check {0}`)", o->out, files.urdf_file,
                            source.robot->name);
    } else {
      const std::string text = cal::calibrated_model_text(source.model_text, source.model_name, result, source.names);
      sim::parse_model_file(YamlReader::from_string(text, o->out));  // what is written must load
      std::ofstream out(o->out);
      if (!(out << text)) throw InputError(fmt::format("--out {}: cannot write", o->out));
    }
    if (o->json) {
      std::cout << result_json(result, o->out).dump() << std::endl;
    } else {
      print_result(result, written);
    }
  });
}

}  // namespace cpgmatch::cli
