// A study as an experiment one can re-derive:
//   cpgmatch study resolve --config STUDY.yaml [--json]
//       the spec a study file resolves to on this release's defaults (what `study submit` stores)
//   cpgmatch study show --store PATH [--study ID] [--json]
//       its spec as a study file that `study submit` accepts and that resolves to the same spec hash
//   cpgmatch rerun --store PATH --study ID --trial N [--json]
//       re-runs a stored trial from the store alone (spec, parameters, seed) and prints the stored and the
//       recomputed cost; for a simulated trial they are equal to the bit
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "cpgmatch/analysis/stored_study_trials.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/study/robot_file.hpp"
#include "cpgmatch/study/spec_rollout.hpp"
#include "cpgmatch/text.hpp"
#include "study_analysis.hpp"

namespace cpgmatch::cli {

namespace {

const study::StoredTrial& find_trial(const study::StoredStudy& stored, int trial_id) {
  for (const auto& t : stored.trials) {
    if (t.trial_id == trial_id) return t;
  }
  throw InputError(fmt::format("--trial {}: study {} has no such trial (it has {})", trial_id, stored.study_id,
                               stored.trials.size()));
}

// The spec as a study file (or JSON with its hash and origin).
void print_spec(const study::StudySpec& spec, const std::string& origin, bool json, const std::string& header) {
  if (json) {
    std::cout << nlohmann::json{{"sha256", spec.sha256()},
                                {"spec_key", study::spec_key_hex(spec.key())},
                                {"objective_version", spec.objective_version()},
                                {"origin", origin},
                                {"spec", spec.tree()}}
                     .dump()
              << std::endl;
    return;
  }
  std::cout << header << spec.to_study_yaml();
}

}  // namespace

void add_spec_commands(CLI::App& app, CLI::App* study) {
  {
    struct Options {
      std::string config;
      bool json = false;
    };
    auto o = std::make_shared<Options>();
    CLI::App* cmd = study->add_subcommand(
        "resolve", "the spec a study file resolves to on this release's defaults (what submit would store)");
    cmd->add_option("--config", o->config, "study YAML")->required();
    cmd->add_flag("--json", o->json, "the canonical JSON tree with its hash instead");
    cmd->callback([o] {
      const study::StudySpec spec =
          study::StudySpec::resolve(study::with_named_files(read_text_file(o->config, "--config"), o->config),
                                    o->config, study::SpecDefaults::shipped());
      print_spec(spec, "resolved from " + o->config, o->json, "");
    });
  }
  {
    struct Options {
      std::string store;
      int study = 0;
      bool json = false;
    };
    auto o = std::make_shared<Options>();
    CLI::App* cmd = study->add_subcommand("show", "a stored study's spec, as a study file that resubmits to the same spec");
    cmd->add_option("--store", o->store, "SQLite study store")->required();
    cmd->add_option("--study", o->study, "study id (default: the last study in the store)");
    cmd->add_flag("--json", o->json, "the canonical JSON tree with its hash and origin instead");
    cmd->callback([o] {
      if (o->study < 0) throw InputError(fmt::format("--study {}: study ids are >= 1", o->study));
      const study::StoredStudy stored = analysis::load_stored_study(o->store, o->study);
      const auto spec = stored_spec(stored);
      const std::string origin =
          stored.spec.origin.empty() ? "not yet migrated: resolved now from this release's defaults" : stored.spec.origin;
      print_spec(*spec, origin, o->json,
                 fmt::format("# study {} of {}; origin: {}\n", stored.study_id, o->store, origin));
    });
  }
  {
    struct Options {
      std::string store;
      int study = 0;
      int trial = -1;
      bool json = false;
    };
    auto o = std::make_shared<Options>();
    CLI::App* cmd = app.add_subcommand("rerun", "re-run a stored trial from the store alone; prints stored and recomputed cost");
    cmd->add_option("--store", o->store, "SQLite study store")->required();
    cmd->add_option("--study", o->study, "study id")->required();
    cmd->add_option("--trial", o->trial, "trial id")->required();
    cmd->add_flag("--json", o->json, "one JSON object");
    cmd->callback([o] {
      if (o->study < 1) throw InputError(fmt::format("--study {}: study ids are >= 1", o->study));
      if (o->trial < 0) throw InputError(fmt::format("--trial {}: trial ids are >= 0", o->trial));
      const study::StoredStudy stored = analysis::load_stored_study(o->store, o->study);
      const study::StoredTrial& t = find_trial(stored, o->trial);
      if (t.status != study::TrialStatus::kDone) {
        throw InputError(fmt::format("--trial {}: not reported yet (in flight)", o->trial));
      }
      const auto spec = stored_spec(stored);
      const study::StudyConfig& cfg = spec->config();
      const std::map<std::string, double> params = cfg.space.to_named(t.x);
      const std::uint64_t seed = study::trial_seed(*spec, t.trial_id);
      const RolloutResult r =
          sim::run_sim_rollout(study::sim_job_for(*spec, params, cfg.terrain, seed, cfg.entrain_s, cfg.eval_s));
      const std::string kind = t.report.is_object() ? t.report.value("worker_kind", "sim") : "sim";
      const bool stored_ok = t.ok;
      const bool equal = stored_ok && r.cost == t.cost;
      // A spec of another objective version was computed by other science: this release re-runs it with its
      // own, and says so (equality is then a finding, not a guarantee).
      const bool other_version = spec->objective_version() != study::kObjectiveVersion;
      if (other_version) {
        fmt::print(stderr,
                   "note: study {}'s spec is objective version {}; this release computes version {}, so the rerun may "
                   "differ for reasons of the science, not of the store\n",
                   stored.study_id, spec->objective_version(), study::kObjectiveVersion);
      }
      if (o->json) {
        std::cout << nlohmann::json{{"study_id", stored.study_id},
                                    {"trial_id", t.trial_id},
                                    {"worker_kind", kind},
                                    {"spec_sha256", spec->sha256()},
                                    {"spec_objective_version", spec->objective_version()},
                                    {"rerun_objective_version", study::kObjectiveVersion},
                                    {"seed", seed},
                                    {"params", params},
                                    {"stored_ok", stored_ok},
                                    {"stored_cost", stored_ok ? nlohmann::json(t.cost) : nlohmann::json(nullptr)},
                                    {"recomputed_cost", r.cost},
                                    {"recomputed_outcome", to_string(r.outcome)},
                                    {"equal", equal}}
                         .dump()
                  << std::endl;
      } else {
        fmt::print("study {} trial {} ({} worker), spec {}\n", stored.study_id, t.trial_id, kind, spec->sha256().substr(0, 16));
        fmt::print("stored cost     {}\n", stored_ok ? fmt::format("{:.17g}", t.cost) : std::string("(failed: did not run)"));
        fmt::print("recomputed cost {:.17g} ({})\n", r.cost, to_string(r.outcome));
        fmt::print("{}\n", equal ? "equal to the bit"
                           : kind == "hardware" ? "differs: a hardware trial re-runs in simulation"
                           : other_version      ? "differs: the spec is of another objective version"
                                                : "DIFFERS");
      }
    });
  }
}

}  // namespace cpgmatch::cli
