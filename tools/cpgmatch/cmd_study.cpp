// `cpgmatch study run`: a full local study (the paper's, by default). Starts the optimizer service and
// simulation workers as child processes on a private DDS domain (UDP on loopback only),
// submits the study, shows progress until it is done and stops them. At the end it writes trials, a
// summary and plots from the trial records it read over DDS, and compares with the paper.
#include <unistd.h>

#include <csignal>
#include <iterator>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numeric>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "child_process.hpp"
#include "cpgmatch/command_objective.hpp"
#include "cpgmatch/dds/domain.hpp"
#include "service_flags.hpp"
#include "study_client.hpp"
#include "cpgmatch/study/study_config.hpp"

namespace cpgmatch::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double mean(const std::vector<double>& v) {
  return v.empty() ? std::nan("") : std::accumulate(v.begin(), v.end(), 0.0) / v.size();
}

class ProgressBar {
 public:
  ProgressBar(int total, bool quiet) : total_(total), quiet_(quiet), tty_(isatty(STDERR_FILENO)) {}
  void update(int done, double best, double elapsed) {
    if (quiet_) return;
    const double rate = elapsed > 0 ? done / elapsed : 0.0;
    const double eta = rate > 0 ? (total_ - done) / rate : 0.0;
    const int width = 30, filled = total_ > 0 ? width * done / total_ : width;
    std::string bar(filled, '#');
    bar += std::string(width - filled, '.');
    fmt::print(stderr, "{}[{}] {:>4}/{} best {:<9.4g} {:5.2f} rollouts/s  elapsed {:5.1f}s  eta {:5.1f}s{}",
               tty_ ? "\r" : "", bar, done, total_, best, rate, elapsed, eta, tty_ ? "" : "\n");
    if (tty_ && done == total_) fmt::print(stderr, "\n");
  }

 private:
  int total_;
  bool quiet_;
  bool tty_;
};

void write_plots(const fs::path& dir, const std::vector<json>& trials, int initial, bool quiet) {
  {
    std::ofstream data(dir / "trials.dat");
    data << "# index cost best_so_far normalized_torque feedback fell\n";
    double best = std::numeric_limits<double>::infinity();
    for (const auto& t : trials) {
      const double cost = t.value("cost", std::nan(""));
      if (std::isfinite(cost)) best = std::min(best, cost);
      const auto& r = t["result"];
      const bool ok = r.is_object();
      data << fmt::format("{} {} {} {} {} {}\n", t["index"].get<int>(), std::isfinite(cost) ? cost : 0.0, best,
                          ok && !r["fell"].get<bool>() ? r["normalized_torque"].get<double>() : std::nan(""),
                          ok && !r["fell"].get<bool>() ? r["terms"]["feedback"].get<double>() : std::nan(""),
                          ok ? int(r["fell"].get<bool>()) : 1);
    }
  }
  std::ofstream script(dir / "plots.gp");
  script << "set terminal pngcairo size 1100,800 noenhanced\n"
         << "set output '" << (dir / "study.png").string() << "'\n"
         << "set datafile missing 'nan'\nset multiplot layout 3,1\nset grid\n"
         << fmt::format("set arrow from {0},graph 0 to {0},graph 1 nohead dt 2\n", initial - 0.5)
         << "set title 'Cost per rollout (dots, falls in red) and best so far (line); dashed: end of random initial design'\n"
         << "set ylabel 'cost'\nset logscale y\n"
         << "plot 'trials.dat' u 1:($6==0?$2:1/0) w p pt 7 ps 0.6 t 'cost', '' u 1:($6==1?$2:1/0) w p pt 7 ps 0.6 lc rgb 'red' t 'fell', '' u 1:3 w l lw 2 t 'best so far'\n"
         << "set title 'Normalised torque (eq. 1) of rollouts that did not fall (log scale)'\nset ylabel 'N m / (m/s)'\n"
         << "plot 'trials.dat' u 1:4 w p pt 7 ps 0.6 t 'normalised torque'\n"
         << "unset logscale y\nset title 'Feedback activity J_feedback (fraction of time per leg)'\nset ylabel 'fraction'\nset xlabel 'rollout'\n"
         << "plot 'trials.dat' u 1:5 w p pt 7 ps 0.6 t 'J_feedback'\nunset multiplot\n";
  script.close();
  const std::string cmd = fmt::format("cd '{}' && gnuplot plots.gp 2>/dev/null", dir.string());
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    if (!quiet) fmt::print(stderr, "gnuplot not found: data and script written, no PNG ({})\n", (dir / "plots.gp").string());
    return;
  }
  if (std::system(cmd.c_str()) != 0 && !quiet) fmt::print(stderr, "gnuplot failed; see {}\n", (dir / "plots.gp").string());
}

json summarise(const std::vector<json>& trials, int initial) {
  auto ok = [](const json& t) { return t["result"].is_object(); };
  auto walked = [&](const json& t) { return ok(t) && !t["result"]["fell"].get<bool>(); };
  int best_index = -1;
  double best_cost = std::numeric_limits<double>::infinity(), best_initial = best_cost;
  int falls = 0, falls_initial = 0, failed = 0;
  std::vector<double> nt_initial, fb_initial, fb_last;
  for (const auto& t : trials) {
    const int i = t["index"].get<int>();
    if (!ok(t)) {
      ++failed;
      continue;
    }
    const auto& r = t["result"];
    const double c = r["cost"].get<double>();
    if (c < best_cost) {
      best_cost = c;
      best_index = i;
    }
    if (i < initial) best_initial = std::min(best_initial, c);
    if (r["fell"].get<bool>()) {
      ++falls;
      if (i < initial) ++falls_initial;
    }
    if (walked(t) && i < initial) {
      nt_initial.push_back(r["normalized_torque"].get<double>());
      fb_initial.push_back(r["terms"]["feedback"].get<double>());
    }
    if (walked(t) && i >= static_cast<int>(trials.size()) - initial) fb_last.push_back(r["terms"]["feedback"].get<double>());
  }
  json s{{"rollouts", trials.size()}, {"initial_points", initial}, {"failed_evaluations", failed},
         {"falls", falls}, {"falls_in_initial", falls_initial}};
  if (best_index >= 0) {
    const auto& br = trials[best_index]["result"];
    const double nt_best = br["normalized_torque"].get<double>();
    const double nt_init = median(nt_initial);
    s["best_index"] = best_index;
    s["best_cost"] = best_cost;
    s["best_initial_cost"] = std::isfinite(best_initial) ? json(best_initial) : json(nullptr);
    s["best_params"] = br["params"];
    s["best_result"] = br;
    s["best_speed_mps"] = br["mean_speed_mps"];
    s["normalized_torque_best"] = nt_best;
    s["normalized_torque_initial_median"] = std::isfinite(nt_init) ? json(nt_init) : json(nullptr);
    s["normalized_torque_change_percent"] = std::isfinite(nt_init) ? json(100.0 * (nt_best - nt_init) / nt_init) : json(nullptr);
    s["feedback_initial_mean"] = fb_initial.empty() ? json(nullptr) : json(mean(fb_initial));
    s["feedback_last_mean"] = fb_last.empty() ? json(nullptr) : json(mean(fb_last));
    s["feedback_best"] = br["terms"]["feedback"];
  }
  return s;
}

void print_report(const json& s, const study::StudyConfig& cfg, const fs::path& dir, double wall) {
  fmt::print("\nstudy '{}': {} rollouts in {:.1f} s ({:.2f} rollouts/s)\n", cfg.name, s["rollouts"].get<int>(), wall,
             s["rollouts"].get<int>() / wall);
  if (!s.contains("best_cost")) {
    fmt::print("  no successful rollout\n");
    return;
  }
  auto num = [&](const char* key) { return s[key].is_null() ? std::nan("") : s[key].get<double>(); };
  fmt::print("                                  this run      paper (Ruppert & Badri-Sproewitz 2022)\n");
  fmt::print("  best cost                       {:8.3f}      2.59\n", num("best_cost"));
  fmt::print("  best of the {:>2} random rollouts   {:8.3f}      (random initial design)\n", s["initial_points"].get<int>(),
             num("best_initial_cost"));
  fmt::print("  normalised torque, best         {:8.2f}      1.02\n", num("normalized_torque_best"));
  fmt::print("  normalised torque, initial med. {:8.2f}      2.52 (initial)\n", num("normalized_torque_initial_median"));
  fmt::print("  normalised torque change        {:+7.0f}%      -42%\n", num("normalized_torque_change_percent"));
  fmt::print("  J_feedback initial -> last {:>2}   {:.3f} -> {:.3f}   (best {:.3f}; paper best 0.13)\n",
             s["initial_points"].get<int>(), num("feedback_initial_mean"), num("feedback_last_mean"), num("feedback_best"));
  fmt::print("  falls                           {:>3} ({} in initial)  16 (9 in initial)\n", s["falls"].get<int>(),
             s["falls_in_initial"].get<int>());
  fmt::print("  best gait speed                 {:8.3f}      0.3 m/s\n", num("best_speed_mps"));
  fmt::print("  best parameters                 {}\n", s["best_params"].dump());
  fmt::print("  results: {}  (study.png, trials.jsonl, summary.json, best_params.yaml)\n", dir.string());
}

// The trial record (to_json(TrialRecord)) in the shape summarise() and the plots read.
json legacy_trial(const json& record) {
  const json& report = record["report"];
  json t{{"index", record["trial_id"]}, {"ok", report["ok"]}, {"params", record["params"]}};
  if (report["ok"].get<bool>()) {
    json result = report;
    result["params"] = record["params"];
    t["result"] = result;
    t["cost"] = report["cost"];
  } else {
    t["result"] = nullptr;
    t["cost"] = nullptr;
    t["error"] = report["error"];
  }
  return t;
}

// A domain id of this run's own, so that two local studies on one machine do not meet.
int private_domain() { return 150 + static_cast<int>(getpid() % 80); }

volatile std::sig_atomic_t g_interrupted = 0;

}  // namespace

void add_study_command(CLI::App& app) {
  CLI::App* study = app.add_subcommand("study", "run and manage optimisation studies");
  study->require_subcommand(1);
  add_study_service_commands(study);
  struct Options {
    std::string config;
    int workers = 0;
    std::string out;
    std::string store;
    int domain = -1;
    bool quiet = false;
    bool json = false;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* run = study->add_subcommand(
      "run", "run a study locally to completion: optimizer service and workers as child processes on a private DDS domain");
  run->add_option("--config", opts->config, "study YAML (default: the paper's study)");
  run->add_option("--workers", opts->workers, "simulation workers, one rollout each at a time (default: number of cores)");
  run->add_option("--out", opts->out, "results directory (default: results/<name>-<time>)");
  run->add_option("--store", opts->store, "SQLite study store (default: <out>/study.db)");
  run->add_option("--domain", opts->domain, "DDS domain id (default: a private one, 150..229)");
  run->add_flag("--quiet", opts->quiet, "no progress bar");
  run->add_flag("--json", opts->json, "print the summary as one JSON object");
  run->callback([opts] {
    study::StudyConfig cfg;
    std::string text = "# the paper's study: every key but the name has the paper's value\nname: paper-study\n";
    std::string source = "embedded paper study";
    if (!opts->config.empty()) {
      cfg = study::load_study_config(opts->config);
      std::ifstream in(opts->config);
      text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
      source = opts->config;
    }
    if (opts->workers < 0) throw InputError("--workers must be >= 1");
    const int workers = opts->workers > 0 ? opts->workers : std::max(1u, std::thread::hardware_concurrency());
    const int domain = opts->domain >= 0 ? opts->domain : private_domain();
    dds::validate_domain(domain);
    const auto stamp = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
    char buf[32];
    std::strftime(buf, sizeof(buf), "%Y%m%d-%H%M%S", std::localtime(&stamp));
    const fs::path dir = opts->out.empty() ? fs::path("results") / fmt::format("{}-{}", cfg.name, buf) : fs::path(opts->out);
    fs::create_directories(dir);
    const std::string store = opts->store.empty() ? (dir / "study.db").string() : opts->store;

    if (!opts->quiet) {
      fmt::print(stderr, "study '{}': {} rollouts ({} random, then {}), {} parameters, {:.0f} s + {:.0f} s each\n",
                 cfg.name, cfg.budget, cfg.optimizer.initial_points, bo::to_string(cfg.optimizer.acquisition),
                 cfg.space.size(), cfg.entrain_s, cfg.eval_s);
      fmt::print(stderr, "optimizer service + {} simulation workers on private DDS domain {}; logs in {}\n", workers,
                 domain, dir.string());
    }
    const fs::path bin = fs::path(self_executable()).parent_path();
    const std::string d = std::to_string(domain);
    std::vector<std::unique_ptr<ChildProcess>> children;
    children.push_back(std::make_unique<ChildProcess>(
        std::vector<std::string>{(bin / "cpgmatch-optimizer").string(), "--domain", d, "--store", store,
                                 "--localhost-only", "--log-level", "warn"},
        (dir / "optimizer.log").string()));
    for (int i = 0; i < workers; ++i) {
      children.push_back(std::make_unique<ChildProcess>(
          std::vector<std::string>{(bin / "cpgmatch-sim-worker").string(), "--domain", d, "--slots", "1", "--id",
                                   fmt::format("local-{}-{}", getpid(), i), "--localhost-only", "--log-level", "warn"},
          (dir / fmt::format("worker-{}.log", i)).string()));
    }
    auto stop_all = [&] {
      for (auto it = children.rbegin(); it != children.rend(); ++it) (*it)->stop();
    };
    std::signal(SIGINT, [](int) { g_interrupted = 1; });
    std::signal(SIGTERM, [](int) { g_interrupted = 1; });

    client::StudyClient client(domain, true, /*read_trials=*/true);
    const auto start = std::chrono::steady_clock::now();
    const client::CommandResult submitted = client.submit(text, source, 30.0);
    if (!submitted.ok) {
      stop_all();
      throw InputError(submitted.message);
    }
    ProgressBar bar(cfg.budget, opts->quiet);
    json state;
    int shown = -1;
    while (true) {
      if (g_interrupted) {
        stop_all();
        throw std::runtime_error(fmt::format("interrupted; the study is kept in {} (resume with --store)", store));
      }
      if (!children.front()->running()) {
        stop_all();
        throw std::runtime_error(fmt::format("the optimizer service exited; see {}", (dir / "optimizer.log").string()));
      }
      if (std::none_of(children.begin() + 1, children.end(), [](auto& c) { return c->running(); })) {
        stop_all();
        throw std::runtime_error(fmt::format("every worker exited; see {}", (dir / "worker-0.log").string()));
      }
      const auto states = client.states();
      if (auto it = states.find(submitted.study_id); it != states.end()) {
        state = it->second;
        const int done = state["completed"].get<int>();
        if (done != shown) {
          bar.update(done, state["best_cost"].is_null() ? std::nan("") : state["best_cost"].get<double>(),
                     std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
          shown = done;
        }
        if (is_terminal(state["state"].get<std::string>())) break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    // Trial records travel on their own topic; give the last ones a moment to arrive.
    std::vector<json> records;
    for (int i = 0; i < 100; ++i) {
      records = client.trials(submitted.study_id);
      if (static_cast<int>(records.size()) >= state["completed"].get<int>()) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    stop_all();
    if (state["state"] != "done") {
      throw std::runtime_error(fmt::format("study {} ended {}: {}", submitted.study_id, state["state"].get<std::string>(),
                                           state["message"].get<std::string>()));
    }
    std::vector<json> trials;
    std::ofstream trials_file(dir / "trials.jsonl");
    for (const auto& r : records) {
      trials.push_back(legacy_trial(r));
      trials_file << trials.back().dump() << '\n';
    }
    json summary = summarise(trials, cfg.optimizer.initial_points);
    summary["name"] = cfg.name;
    summary["study_id"] = submitted.study_id;
    summary["wall_time_s"] = wall;
    summary["workers"] = workers;
    summary["store"] = store;
    summary["reissued"] = state["reissued"];
    std::ofstream(dir / "summary.json") << summary.dump(2) << '\n';
    if (summary.contains("best_params")) {
      std::ofstream yaml(dir / "best_params.yaml");
      yaml << fmt::format("# best parameters of study '{}' (cost {:.4f}, rollout {})\n", cfg.name,
                          summary["best_cost"].get<double>(), summary["best_index"].get<int>());
      for (const auto& [k, v] : summary["best_params"].items()) yaml << k << ": " << v.get<double>() << '\n';
    }
    write_plots(dir, trials, cfg.optimizer.initial_points, opts->quiet);
    if (opts->json) std::cout << summary.dump() << std::endl;
    else print_report(summary, cfg, dir, wall);
  });
}

}  // namespace cpgmatch::cli
