// cpgmatch-optimizer: the central optimizer service. Hosts any number of studies, each with its own
// Bayesian optimizer; hands candidates to the workers it hears on the domain and keeps their slots
// busy; stores everything in an SQLite file and resumes from it after a restart.
//
//   cpgmatch-optimizer --domain 7 --store studies.db
//
// DDS listeners only queue samples; one thread runs the coordinator (see coordinator.hpp); model fits and
// acquisition optimisation run on --model-threads threads beside it.
#include <malloc.h>

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <optional>
#include <thread>
#include <variant>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "cpgmatch/dds/convert.hpp"
#include "cpgmatch/dds/convert_trace.hpp"
#include "cpgmatch/dds/domain.hpp"
#include "cpgmatch/dds/participant.hpp"
#include "cpgmatch/dds/ros2_view.hpp"
#include "cpgmatch/dds/security.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/runtime/install_layout.hpp"
#include "cpgmatch/runtime/man_pages.hpp"
#include "cpgmatch/runtime/shared_flags.hpp"
#include "cpgmatch/service/coordinator.hpp"
#include "cpgmatch/study/store_lock.hpp"
#include "event_queue.hpp"
#include "loop_latency.hpp"
#include "trace_intake.hpp"

namespace cpgmatch::service {
namespace {

volatile std::sig_atomic_t g_stop = 0;
volatile std::sig_atomic_t g_print_stats = 0;
void on_signal(int) { g_stop = 1; }
void on_stats_signal(int) { g_print_stats = 1; }

// Monotonic: the coordinator's timeouts and leases run on it (the store gets Unix time separately).
double monotonic_now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct WorkerGone {
  std::uint64_t key;
  bool disposed;                           // the worker disposed its announcement: it left cleanly
  std::optional<std::string> disposed_by;  // with DDS-Security: the disposing participant's CN
};
struct ModelResult {};  // a model job finished: wake up and apply it
// A worker's sample with the identity DDS-Security authenticated for its writer (nothing without security),
// looked up when it arrives: the coordinator decides whether that identity may speak for its worker_id.
template <class T>
struct From {
  T sample;
  std::optional<std::string> sender;
};
using Sample = std::variant<msg::StudyCommand, From<msg::RolloutReport>, From<msg::WorkerAnnouncement>, WorkerGone,
                            ModelResult, From<msg::RolloutTraceChunk>>;
struct Event {
  Sample sample;
  std::chrono::steady_clock::time_point arrived = std::chrono::steady_clock::now();
};

using Clock = std::chrono::steady_clock;
double seconds_between(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

// What a sample is, for the log line of one that cannot be taken.
std::string describe(const Sample& sample) {
  return std::visit(
      [](const auto& e) -> std::string {
        using T = std::decay_t<decltype(e)>;
        if constexpr (std::is_same_v<T, msg::StudyCommand>) {
          return fmt::format("command from {}", e.client_id().to_string());
        } else if constexpr (std::is_same_v<T, From<msg::RolloutReport>>) {
          return fmt::format("report for study {} trial {} from {}", e.sample.study_id(), e.sample.trial_id(),
                             e.sample.worker_id().to_string());
        } else if constexpr (std::is_same_v<T, From<msg::WorkerAnnouncement>>) {
          return fmt::format("worker announcement {}", e.sample.worker_id().to_string());
        } else {
          return "event";
        }
      },
      sample);
}

// Whether a worker's sample may be shown on the ROS 2 view: with DDS-Security only from the identity that owns
// its worker id (the coordinator's rule for counting it).
bool may_show_worker(bool secure, const std::optional<std::string>& sender, const std::string& worker_id) {
  return !secure || (sender && dds::worker_id_belongs_to(worker_id, *sender));
}

// Hands one sample to the coordinator. A store that cannot be written stops the service (the caller's
// transaction rolls back, nothing unrecorded was acknowledged); any other error drops only this sample.
void dispatch(Coordinator& coordinator, TraceIntake& traces, Event& event, dds::Ros2View* ros2, bool secure) {
  const double now = monotonic_now_s();
  // A trace chunk goes to the trace intake, never to the coordinator: a trace cannot touch a study.
  if (auto* chunk = std::get_if<From<msg::RolloutTraceChunk>>(&event.sample)) {
    try {
      traces.add(dds::from_wire(chunk->sample), now, chunk->sender);
    } catch (const dds::WireError& e) {
      traces.reject(e.what());
    } catch (const study::StoreWriteError&) {
      throw;  // as below: the store cannot be written, the service stops and says so
    } catch (const std::exception& e) {
      traces.reject(e.what());  // whatever else a chunk provokes, it must not take the service down
    }
    return;
  }
  try {
    std::visit(
        [&](auto& e) {
          using T = std::decay_t<decltype(e)>;
          // The wire stops here: the coordinator sees domain values only (dds::from_wire, convert.hpp).
          if constexpr (std::is_same_v<T, msg::StudyCommand>) {
            coordinator.handle_command(dds::from_wire(e), now);
          } else if constexpr (std::is_same_v<T, From<msg::RolloutReport>>) {
            coordinator.handle_report(dds::from_wire(e.sample), now, e.sender);
          } else if constexpr (std::is_same_v<T, From<msg::WorkerAnnouncement>>) {
            const domain::WorkerAnnouncement announcement = dds::from_wire(e.sample);
            coordinator.handle_worker(announcement, now, e.sender);
            if (ros2 != nullptr && may_show_worker(secure, e.sender, announcement.worker_id) &&
                !ros2->publish_worker(announcement)) {
              spdlog::warn("DDS write of a ROS 2 worker failed");
            }
          } else if constexpr (std::is_same_v<T, WorkerGone>) {
            coordinator.handle_worker_gone(e.key, now, e.disposed ? WorkerExit::kLeft : WorkerExit::kLost, e.disposed_by);
            // A dispose counts only from the worker's own identity (disposed_by is set with DDS-Security only).
            const bool shown = ros2 != nullptr && (!e.disposed_by || may_show_worker(secure, e.disposed_by,
                                                                                     ros2->worker_id_of(e.key)));
            if (shown && !ros2->worker_gone(e.key)) spdlog::warn("DDS write of a ROS 2 worker failed");
          }
        },
        event.sample);
  } catch (const dds::WireError& e) {
    coordinator.reject_sample(describe(event.sample), e.what());
  } catch (const study::StoreWriteError&) {
    throw;  // disk full, read-only store: stop and say so (run_reporting_errors)
  } catch (const std::exception& e) {
    // A sample that slipped past validation must not take the service down.
    spdlog::error("event dropped: {}", e.what());
  }
}

// Model threads by default: one per core. They run niced, so the event thread still gets a core when it
// needs one; with 20 studies on 2 cores, 2 threads gave 104 results/s against 78 for 1
// (tests/bench/proposal_throughput.sh).
int default_model_threads() {
  const int cores = static_cast<int>(std::thread::hardware_concurrency());
  return std::clamp(cores, 1, 16);
}

// Publishes what the coordinator decides, and the same again on the ROS 2 view when there is one.
class DdsOutbox final : public Outbox {
 public:
  DdsOutbox(dds::Participant& p, dds::Ros2View* ros2)
      : candidates_(p), trials_(p), states_(p), replies_(p), specs_(p), ros2_(ros2) {}
  void send_candidate(const domain::Candidate& c) override { check(candidates_.write(dds::to_wire(c)), "candidate"); }
  void retire_candidate(const domain::Candidate& c) override { candidates_.unregister(dds::to_wire(c)); }
  void publish_trial(const domain::TrialRecord& t) override {
    check(trials_.write(dds::to_wire(t)), "trial record");
    if (ros2_ != nullptr) check(ros2_->publish_trial(t), "ROS 2 trial record");
  }
  void retire_trial(const domain::TrialRecord& t) override {
    trials_.unregister(dds::to_wire(t));
    if (ros2_ != nullptr) ros2_->retire_study(t.study_id);
  }
  void publish_state(const domain::StudyState& s) override {
    check(states_.write(dds::to_wire(s)), "study state");
    if (ros2_ != nullptr) check(ros2_->publish_state(s), "ROS 2 study state");
  }
  void reply(const domain::CommandReply& r) override { check(replies_.write(dds::to_wire(r)), "command reply"); }
  void publish_spec(const domain::SpecPublication& s) override { check(specs_.write(dds::to_wire(s)), "study spec"); }
  void retire_spec(const domain::SpecPublication& s) override { specs_.unregister(dds::to_wire(s)); }

  // Gives what was already published, and so acknowledged by a committed transaction, up to `timeout` to
  // reach its readers. Called before the service stops on a store error: a study accepted a few
  // milliseconds before the disk filled must still be answered, not lost with the writers as the process
  // exits. False if some reader had not acknowledged everything in time.
  bool flush(std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    auto left = [&] {
      return std::max(std::chrono::milliseconds(0),
                      std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()));
    };
    bool all = replies_.wait_for_acknowledgments(left());
    all = states_.wait_for_acknowledgments(left()) && all;
    all = trials_.wait_for_acknowledgments(left()) && all;
    return all;
  }

 private:
  static void check(bool ok, const char* what) {
    if (!ok) spdlog::warn("DDS write of a {} failed", what);
  }
  dds::Writer<msg::Candidate> candidates_;
  dds::Writer<msg::TrialRecord> trials_;
  dds::Writer<msg::StudyState> states_;
  dds::Writer<msg::CommandReply> replies_;
  dds::Writer<msg::StudySpecSample> specs_;
  dds::Ros2View* ros2_;
};

// The ROS 2 view (docs/ros2.md), or nothing when it is off or cannot be created: it is a read-only mirror,
// and an enclave of a keystore made before it existed may not publish rt/ topics; the service runs on.
std::unique_ptr<dds::Ros2View> make_ros2_view(dds::Participant& participant, bool wanted, bool type_info) {
  if (!wanted) return nullptr;
  try {
    return std::make_unique<dds::Ros2View>(participant, type_info);
  } catch (const std::exception& e) {
    spdlog::warn("no ROS 2 view (rt/cpgmatch/*): {}{}; the native cpgmatch/ topics are unaffected", e.what(),
                 dds::selected_enclave().empty() ? ""
                                                 : " (DDS-Security: the permissions of a keystore made before the view "
                                                   "do not name its topics; make a new one, docs/ros2.md)");
    return nullptr;
  }
}

int run(int domain, const std::string& store_path, bool full_durability, double worker_timeout_s, bool localhost_only,
        int model_threads, int acquisition_threads, bool ros2_view, bool ros2_type_info) {
  dds::validate_domain(domain);
  if (worker_timeout_s <= 0.0) throw InputError("--worker-timeout must be > 0");
  if (model_threads < 1 || model_threads > 64) throw InputError("--model-threads must be in [1, 64]");
  if (acquisition_threads < 1 || acquisition_threads > 16) throw InputError("--acquisition-threads must be in [1, 16]");
  const study::StoreLock lock(store_path);  // before the store is touched: one optimizer per store
  std::unique_ptr<study::StudyStore> opened;
  try {
    opened = std::make_unique<study::StudyStore>(store_path, full_durability ? study::Durability::kFull
                                                                             : study::Durability::kNormal);
    opened->require_writable();
  } catch (const study::StoreWriteError& e) {
    throw InputError(fmt::format("--store: {}", e.what()));  // an unusable --store, like a locked one: exit 2
  }
  study::StudyStore& store = *opened;
  service::CoordinatorOptions options;
  options.worker_timeout_s = worker_timeout_s;
  options.model_threads = model_threads;
  options.acquisition_threads = acquisition_threads;
  // A submit's spec is resolved beside the event loop; with --model-threads 0 (everything inline) on it.
  options.resolve_specs_off_thread = model_threads > 0;
  options.where = fmt::format("domain {}", domain);
  service::EventQueue<Event> queue;
  options.on_model_result = [&queue] { queue.push(Event{ModelResult{}}); };
  // With DDS-Security, a report or an announcement counts only from a participant whose certificate owns
  // its worker_id (docs/deploy.md, "Who may speak for a worker").
  const bool secure = !dds::selected_enclave().empty();
  options.require_authenticated_workers = secure;

  dds::ParticipantConfig dds_config;
  dds_config.domain = domain;
  dds_config.name = "cpgmatch-optimizer";
  dds_config.localhost_only = localhost_only;
  // Two optimizers on one domain would both answer commands and publish colliding study ids: say so loudly.
  dds_config.on_peer_discovered = [domain](const std::string& name) {
    if (name == "cpgmatch-optimizer") {
      spdlog::error("another cpgmatch-optimizer joined DDS domain {}: two optimizers on one domain answer the same "
                    "commands and publish colliding study ids; stop one of them or use another --domain",
                    domain);
    }
  };
  dds_config.track_identities = secure;
  dds_config.on_identity_refused = [](const std::string& why) { spdlog::warn("{}", why); };
  dds_config.serve_type_lookup = ros2_view && ros2_type_info;  // the ROS 2 view's types, for DDS Record & Replay
  dds::Participant participant(dds_config);
  const std::unique_ptr<dds::Ros2View> ros2 = make_ros2_view(participant, ros2_view, ros2_type_info);
  DdsOutbox dds_outbox(participant, ros2.get());
  DeferredOutbox outbox(dds_outbox);
  service::Coordinator coordinator(
      store, outbox, options, [](const std::string& m) { spdlog::info("{}", m); },
      [](const std::string& m) { spdlog::warn("{}", m); });
  coordinator.resume_from_store(monotonic_now_s());
  TraceIntake traces(
      store, secure, [](const std::string& m) { spdlog::info("{}", m); }, [](const std::string& m) { spdlog::warn("{}", m); });

  dds::Reader<msg::StudyCommand> commands(participant, [&](const msg::StudyCommand& c) { queue.push(Event{c}); });
  auto sender = [&](const dds::SampleOrigin& o) { return secure ? participant.identity_of(o.participant) : std::nullopt; };
  dds::Reader<msg::RolloutReport> reports(
      participant, dds::Reader<msg::RolloutReport>::WithOrigin{},
      [&](const msg::RolloutReport& r, const dds::SampleOrigin& o) {
        queue.push(Event{From<msg::RolloutReport>{r, sender(o)}});
      });
  dds::Reader<msg::WorkerAnnouncement> workers(
      participant, dds::Reader<msg::WorkerAnnouncement>::WithOrigin{},
      [&](const msg::WorkerAnnouncement& w, const dds::SampleOrigin& o) {
        queue.push(Event{From<msg::WorkerAnnouncement>{w, sender(o)}});
      },
      [&](const msg::WorkerAnnouncement& key, dds::InstanceGone gone) {
        // A dispose is a sample like any other: with DDS-Security only the worker's own identity may send it
        // (an unknown sender is ""). Lost writers and liveliness are not anyone's claim: no identity.
        std::optional<std::string> by;
        if (secure && gone.disposed) by = sender(gone.origin).value_or("");
        queue.push(Event{WorkerGone{key.worker_key(), gone.disposed, by}});
      });
  dds::Reader<msg::RolloutTraceChunk> trace_chunks(
      participant, dds::Reader<msg::RolloutTraceChunk>::WithOrigin{},
      [&](const msg::RolloutTraceChunk& c, const dds::SampleOrigin& o) {
        queue.push(Event{From<msg::RolloutTraceChunk>{c, sender(o)}});
      });
  spdlog::info("optimizer on domain {} with store {} ({} studies, {} model threads)", domain, store_path,
               coordinator.studies(), model_threads);

  LatencyRecorder sample_latency, tick_duration;
  // Where a sample's latency goes: waiting in the queue for the event thread, then its chunk's handling,
  // store commit and publishing (DDS writes), each measured per chunk.
  LatencyRecorder queue_wait, chunk_handling, chunk_commit, chunk_publish, tick_commit, tick_publish;
  auto log_latency = [&] {
    spdlog::info("event loop: sample arrival to handled: {}; tick: {}", sample_latency.summary(), tick_duration.summary());
    spdlog::info("event loop breakdown: queue wait: {}; chunk handling: {}; commit: {}; publish: {}; tick commit: {}; "
                 "tick publish: {}",
                 queue_wait.summary(), chunk_handling.summary(), chunk_commit.summary(), chunk_publish.summary(),
                 tick_commit.summary(), tick_publish.summary());
  };
  // Each burst of samples drained from the queue is handled in one store transaction, and so is each tick;
  // what they publish is held until that transaction commits (DeferredOutbox), so nothing is acknowledged
  // that the store does not hold, as when each write committed on its own, at one commit per burst.
  struct PhaseTimes {
    LatencyRecorder* handling = nullptr;
    LatencyRecorder* commit = nullptr;
    LatencyRecorder* publish = nullptr;
  };
  auto in_one_transaction = [&](auto&& body, PhaseTimes times = {}) {
    auto record = [](LatencyRecorder* r, Clock::time_point since) {
      if (r != nullptr) r->add(seconds_between(since, Clock::now()));
    };
    study::StudyStore::Batch batch(store);
    outbox.hold();
    try {
      const auto start = Clock::now();
      body();
      record(times.handling, start);
      const auto commit_start = Clock::now();
      batch.commit();
      record(times.commit, commit_start);
    } catch (...) {
      outbox.discard();  // rolled back: none of it happened
      throw;
    }
    const auto publish_start = Clock::now();
    outbox.release();
    record(times.publish, publish_start);
  };
  try {
    while (!g_stop) {
      auto events = queue.drain(std::chrono::milliseconds(20));
      // A long burst goes in chunks (kMaxChunkEvents samples or kMaxChunk of handling, whichever comes
      // first), so the first sample of a burst is not acknowledged only after the last one is handled.
      constexpr std::size_t kMaxChunkEvents = 16;
      constexpr auto kMaxChunk = std::chrono::milliseconds(2);
      for (std::size_t first = 0; first < events.size();) {
        std::size_t last = first;
        in_one_transaction([&] {
          const auto chunk_start = Clock::now();
          queue_wait.add(seconds_between(events[first].arrived, chunk_start));
          while (last < events.size() && last - first < kMaxChunkEvents && Clock::now() - chunk_start < kMaxChunk) {
            dispatch(coordinator, traces, events[last++], ros2.get(), secure);
          }
        }, PhaseTimes{&chunk_handling, &chunk_commit, &chunk_publish});
        // Handled = committed and its effects published.
        const auto handled = Clock::now();
        for (std::size_t i = first; i < last; ++i) {
          if (!std::holds_alternative<ModelResult>(events[i].sample)) {
            sample_latency.add(seconds_between(events[i].arrived, handled));
          }
        }
        first = last;
      }
      const auto tick_start = Clock::now();
      in_one_transaction([&] {
        coordinator.tick(monotonic_now_s());
        traces.tick(monotonic_now_s());
      }, PhaseTimes{nullptr, &tick_commit, &tick_publish});
      tick_duration.add(seconds_between(tick_start, Clock::now()));
      if (g_print_stats) {
        g_print_stats = 0;
        log_latency();
      }
    }
  } catch (const study::StoreWriteError&) {
    // Stop (run_reporting_errors names the store), but first let replies and states already committed reach
    // their readers: the rolled-back transaction published nothing, the earlier ones did.
    if (!dds_outbox.flush(std::chrono::seconds(2))) {
      spdlog::warn("stopping on a store error: some published replies or states were not acknowledged in 2 s");
    }
    throw;
  }
  log_latency();
  spdlog::info("rollout traces: {} stored, {} rejected", traces.stored(), traces.rejected());
  spdlog::info("optimizer stopping; waiting for running model jobs; every study is in {}", store_path);
  coordinator.wait_for_models();
  coordinator.apply_model_results();  // their model states go to the store
  return kExitOk;
}

}  // namespace
}  // namespace cpgmatch::service

int main(int argc, char** argv) {
  using namespace cpgmatch;
  // Model jobs allocate and free matrices of 0.1-2 MB many times per proposal (kernels of 1000 candidates,
  // n x n factors). Above glibc's default thresholds each one is a fresh mmap (or a trimmed heap top) whose
  // pages fault in again on every use: 85 000 page faults and a quarter of the model CPU in a 150-trial
  // study. Served from the heap and kept there, they are reused; the heap stays at its peak (tens of MB).
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 128 << 20);
  using cpgmatch::service::on_signal;
  CLI::App app{"cpgmatch-optimizer: the central optimizer service (studies, candidates, reports over DDS)"};
  int domain = -1;
  std::string store = "cpgmatch-studies.db";
  bool full_durability = false, localhost_only = false, no_ros2_view = false, ros2_type_info = false;
  double worker_timeout_s = 2.5;
  int model_threads = service::default_model_threads();
  int acquisition_threads = std::min(service::default_model_threads(), 2);
  std::string log_level = "info";
  app.add_option("--domain", domain, "DDS domain id (default: $CPGMATCH_DOMAIN, else $ROS_DOMAIN_ID, else 0)");
  app.add_option("--store", store, "SQLite study store; created if missing, resumed if present")->capture_default_str();
  app.add_flag("--fsync", full_durability, "fsync every commit (survives power loss, not only a crash)");
  app.add_option("--worker-timeout", worker_timeout_s, "seconds without a heartbeat before a worker is dropped")
      ->capture_default_str();
  app.add_option("--model-threads", model_threads,
                 "threads for GP fits and acquisition optimisation (a study's model work runs on one at a time)")
      ->capture_default_str();
  app.add_option("--acquisition-threads", acquisition_threads,
                 "threads one model job uses for its acquisition search (the same proposals for any number)")
      ->capture_default_str();
  app.add_flag("--localhost-only", localhost_only, "UDP on 127.0.0.1 only (a private study on one machine)");
  app.add_flag("--no-ros2-view", no_ros2_view,
               "do not publish the ROS 2 view (rt/cpgmatch/study_state, trials, workers; docs/ros2.md)");
  app.add_flag("--ros2-type-info", ros2_type_info,
               "announce the ROS 2 view's types (XTypes TypeInformation, TypeLookup service) for eProsima DDS Record & "
               "Replay; ROS 2 nodes on Cyclone DDS 0.10 then see no view (docs/ros2.md)");
  app.add_option("--log-level", log_level, "log level")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
  runtime::DdsFlags dds_flags;
  runtime::add_dds_flags(app, dds_flags, "optimizer");
  runtime::add_version_flag(app, "cpgmatch-optimizer");
  runtime::add_man_page_flag(app, "cpgmatch-optimizer");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitBadInput;
  }
  spdlog::set_default_logger(spdlog::stderr_color_mt("optimizer"));
  spdlog::set_level(spdlog::level::from_str(log_level));
  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);
  std::signal(SIGUSR1, service::on_stats_signal);
  // A file-size limit (ulimit -f) reached by the store must be a write error naming the store, like a
  // full disk, not a silent death by SIGXFSZ.
  std::signal(SIGXFSZ, SIG_IGN);
  return run_reporting_errors([&] {
    runtime::export_config_dir();
    runtime::apply_dds_flags(dds_flags);
    return service::run(domain >= 0 ? domain : cpgmatch::dds::default_domain(), store, full_durability,
                        worker_timeout_s, localhost_only, model_threads, acquisition_threads, !no_ros2_view,
                        ros2_type_info);
  });
}
