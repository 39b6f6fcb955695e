// The subcommands of the `cpgmatch` executable; each file registers one with CLI11.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"

namespace cpgmatch::cli {

void add_rollout_command(CLI::App& app);
void add_bench_optimizer_command(CLI::App& app);
void add_optimize_command(CLI::App& app);
void add_eval_rollout_command(CLI::App& app);
void add_study_command(CLI::App& app);
// study submit/pause/resume/stop (under `study`), and status, watch, workers: clients of the service.
void add_study_service_commands(CLI::App* study);
void add_service_commands(CLI::App& app);
// The science of finished studies: analyze (report beside the paper), plot (figures), reproduce (N seeds).
void add_analyze_command(CLI::App& app);
void add_plot_command(CLI::App& app);
void add_reproduce_command(CLI::App& app);
// A stored study's trials as CSV, JSON or an Optuna journal.
void add_export_command(CLI::App& app);
// `report`: a stored study's figures and one self-contained report.html.
void add_report_command(CLI::App& app);
// `dashboard`: a live, read-only web page of every study on a DDS domain.
void add_dashboard_command(CLI::App& app);
// Simulation versus hardware rollouts of a stored (mixed) study.
void add_sim2real_command(CLI::App& app);
// An emergency stop (latched) or its release for robot agents, over DDS.
void add_estop_command(CLI::App& app);
// `study show` (under `study`) and `rerun`: a stored study's spec, and a stored trial re-run from it.
void add_spec_commands(CLI::App& app, CLI::App* study);
// `calibrate`: model values fitted to measured rollout traces.
void add_calibrate_command(CLI::App& app);
// `robot list|check|init`: the shipped robot descriptions, checking one, and a skeleton from a URDF.
void add_robot_command(CLI::App& app);
// `store check` (cmd_store.cpp).
void add_store_command(CLI::App& app);

// Builds a simulation job from the usual files and flags (empty paths: the shipped defaults).
sim::SimRolloutJob make_sim_job(const std::string& params_file, const std::vector<std::string>& assignments,
                                const std::string& settings_file, const std::string& model_file,
                                const std::string& terrain, std::uint64_t seed);

}  // namespace cpgmatch::cli
