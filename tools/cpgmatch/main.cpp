// cpgmatch: the command-line front end. Bad input exits with code 2 and a message naming the field.
#include <iostream>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "did_you_mean.hpp"
#include "study_file_man_page.hpp"
#include "cpgmatch/runtime/man_pages.hpp"
#include "cpgmatch/runtime/version.hpp"
#include "cpgmatch/runtime/install_layout.hpp"
#include "cpgmatch/runtime/shared_flags.hpp"
#include "cpgmatch/text.hpp"

int main(int argc, char** argv) {
  CLI::App app{"cpgmatch: learn to match a CPG to a legged robot's natural dynamics"};
  app.require_subcommand(1);
  cpgmatch::runtime::add_version_flag(app, "cpgmatch");
  cpgmatch::runtime::add_man_page_flag(
      app, "cpgmatch",
      [] { return std::vector{cpgmatch::cli::study_file_man_page(cpgmatch::runtime::version_text("cpgmatch"))}; },
      {"cpgmatch-study(5)"});
  cpgmatch::cli::add_rollout_command(app);
  cpgmatch::cli::add_bench_optimizer_command(app);
  cpgmatch::cli::add_optimize_command(app);
  cpgmatch::cli::add_eval_rollout_command(app);
  cpgmatch::cli::add_study_command(app);
  cpgmatch::cli::add_service_commands(app);
  cpgmatch::cli::add_analyze_command(app);
  cpgmatch::cli::add_plot_command(app);
  cpgmatch::cli::add_export_command(app);
  cpgmatch::cli::add_report_command(app);
  cpgmatch::cli::add_dashboard_command(app);
  cpgmatch::cli::add_reproduce_command(app);
  cpgmatch::cli::add_sim2real_command(app);
  cpgmatch::cli::add_estop_command(app);
  cpgmatch::cli::add_calibrate_command(app);
  cpgmatch::cli::add_robot_command(app);
  cpgmatch::cli::add_store_command(app);
  try {
    cpgmatch::runtime::export_config_dir();  // before parsing: subcommands run inside parse()
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() != 0) {
      if (const auto hint = cpgmatch::cli::unknown_command_hint(app, argc, argv)) {
        std::cerr << "error: " << *hint << "\nRun with --help for more information." << std::endl;
        return cpgmatch::kExitBadInput;
      }
    }
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // CLI11's own message echoes the arguments: escaped like every other message.
    std::cerr << "error: " << cpgmatch::escape_message_lines(e.what()) << "\nRun with --help for more information."
              << std::endl;
    return cpgmatch::kExitBadInput;
  } catch (const cpgmatch::InputError& e) {
    std::cerr << "error: " << cpgmatch::escape_message_lines(e.what()) << std::endl;
    return cpgmatch::kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "error: " << cpgmatch::escape_message_lines(e.what()) << std::endl;
    return cpgmatch::kExitFailure;
  }
  return cpgmatch::kExitOk;
}
