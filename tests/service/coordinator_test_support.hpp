// What the coordinator-level tests share: an Outbox that records what would be published, a store file of the
// running test's own, hand-made samples (a submitted study file, a worker's announcement), and a fixture with
// a Coordinator on that store that a test can "kill" and reopen.
#pragma once

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "cpgmatch/domain/worker_identity.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/service/coordinator.hpp"
#include "cpgmatch/service/outbox.hpp"
#include "cpgmatch/study/study_config.hpp"

namespace cpgmatch::service::test_support {

struct RecordingOutbox : Outbox {
  std::vector<domain::Candidate> candidates;
  std::vector<domain::TrialRecord> trials;
  std::vector<domain::StudyState> states;
  std::vector<domain::CommandReply> replies;
  void send_candidate(const domain::Candidate& c) override { candidates.push_back(c); }
  void retire_candidate(const domain::Candidate&) override {}
  void publish_trial(const domain::TrialRecord& t) override { trials.push_back(t); }
  void retire_trial(const domain::TrialRecord&) override {}
  void publish_state(const domain::StudyState& s) override { states.push_back(s); }
  void reply(const domain::CommandReply& r) override { replies.push_back(r); }
};

inline void remove_store(const std::string& path) {
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(path + suffix);
}

// A store file in the temporary folder named after `prefix`, the process and the running test; none there yet.
inline std::string test_store_path(const std::string& prefix) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            (prefix + "-" + std::to_string(getpid()) + "-" +
                             ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".db"))
                               .string();
  remove_store(path);
  return path;
}

inline domain::StudyCommand submit_command(const std::string& yaml, std::uint64_t correlation_id) {
  domain::StudyCommand c;
  c.correlation_id = correlation_id;
  c.client_id = "test";
  c.kind = domain::CommandKind::kSubmit;
  c.study_yaml = yaml;
  return c;
}

inline domain::WorkerAnnouncement announcement(const std::string& id, int slots, domain::WorkerKind kind) {
  domain::WorkerAnnouncement w;
  w.worker_id = id;
  w.worker_key = domain::worker_key(id);
  w.slots = slots;
  w.accepting = true;
  w.kind = kind;
  return w;
}

// A worker's report of a completed rollout of `c` with this cost (zero cost terms: a synthetic measurement).
inline domain::RolloutReport completed_report(const domain::Candidate& c, double cost, domain::WorkerKind kind) {
  domain::RolloutReport r;
  r.id = c.id;
  r.worker_id = c.worker_id;
  r.worker_kind = kind;
  r.summary.terms = CostTerms{};
  r.summary.distance_m = 0.0;
  r.summary.cost = cost;
  return r;
}

// Why a study file does not load ("" when it does).
inline std::string study_error(const std::string& yaml) {
  try {
    (void)study::load_study_config_text(yaml, "s.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// A Coordinator on a store of the test's own, driven by hand. open() again is a restart on the same file.
class CoordinatorFixture : public ::testing::Test {
 protected:
  explicit CoordinatorFixture(std::string prefix) : prefix_(std::move(prefix)) {}
  void SetUp() override {
    path_ = test_store_path(prefix_);
    open();
  }
  void TearDown() override {
    coordinator_.reset();
    store_.reset();
    remove_store(path_);
  }
  // (Re)opens store and coordinator on the same file, as a restarted service would.
  void open() {
    coordinator_.reset();
    store_ = std::make_unique<study::StudyStore>(path_);
    out_ = RecordingOutbox{};
    answered_ = 0;
    coordinator_ = std::make_unique<Coordinator>(*store_, out_, options(), [](const std::string&) {},
                                                 [this](const std::string& m) { warnings_.push_back(m); });
  }
  // The coordinator's options (a fixed wall clock); a fixture may add its own.
  virtual CoordinatorOptions options() {
    CoordinatorOptions o;
    o.wall_clock_s = [] { return 1.7e9; };
    return o;
  }
  int submit(const std::string& yaml) {
    coordinator_->handle_command(submit_command(yaml, ++correlation_), now_);
    EXPECT_TRUE(out_.replies.back().ok) << out_.replies.back().message;
    return static_cast<int>(out_.replies.back().study_id);
  }
  void worker(const std::string& id, int slots, domain::WorkerKind kind) {
    coordinator_->handle_worker(announcement(id, slots, kind), now_);
  }

  std::string prefix_, path_;
  std::unique_ptr<study::StudyStore> store_;
  RecordingOutbox out_;
  std::unique_ptr<Coordinator> coordinator_;
  std::vector<std::string> warnings_;
  std::size_t answered_ = 0;  // candidates answered so far (the fixture's own answering code counts them)
  std::uint64_t correlation_ = 0;
  double now_ = 1000.0;  // monotonic time handed to the coordinator
};

}  // namespace cpgmatch::service::test_support
