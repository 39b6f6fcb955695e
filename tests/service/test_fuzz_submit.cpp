// Fuzz: a few hundred generated study files (seeded) submitted to the coordinator. None may crash it;
// each is accepted or refused with a reason; nothing refused is stored; the store reopens afterwards.
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "cpgmatch/service/coordinator.hpp"
#include "cpgmatch/study/study_store.hpp"

namespace cpgmatch::service {
namespace {

struct NullOutbox : Outbox {
  std::vector<domain::CommandReply> replies;
  void send_candidate(const domain::Candidate&) override {}
  void retire_candidate(const domain::Candidate&) override {}
  void publish_trial(const domain::TrialRecord&) override {}
  void retire_trial(const domain::TrialRecord&) override {}
  void publish_state(const domain::StudyState&) override {}
  void reply(const domain::CommandReply& r) override { replies.push_back(r); }
};

// One YAML value: valid, at an edge, absurd, of the wrong type, or not even text.
std::string random_value(std::mt19937_64& rng) {
  static const std::vector<std::string> values = {
      "0", "1", "-1", "15", "150", "2000000000", "1e300", "-1e300", ".nan", ".inf", "-.inf", "0.5", "1e-300",
      "\"\"", "abc", "\"\\xff\"", "[1, 2]", "{a: 1}", "[]", "{}", "null", "~", "true", "0x10", "1_000",
      "\"" + std::string(300, 'x') + "\"", "&a 1", "*a", "!!binary aGVsbG8=", "random", "gp_hedge", "flat",
      "rough:0.003", "step:1e9@1", "shift:nan@1", "{entrain_s: 1e12, eval_s: -1}", "{entrain_s: 1, eval_s: 1}",
      "[{name: hip_offset, low: 1, high: -1}]", "[{name: nope, low: 0, high: 1}]", "{frequency: 99}"};
  return values[std::uniform_int_distribution<std::size_t>(0, values.size() - 1)(rng)];
}

std::string random_study(std::mt19937_64& rng) {
  static const std::vector<std::string> keys = {"name", "budget", "initial_points", "initial_design", "acquisition",
                                                "liar", "cost_transform", "seed", "rollout", "terrain", "parameters", "fixed",
                                                "lease_s", "unknown_key", "[k]", "name"};
  std::string yaml;
  if (rng() % 4 != 0) yaml += "name: fuzz\n";  // usually named, so the other keys get checked too
  const int n = static_cast<int>(rng() % 6);
  for (int i = 0; i < n; ++i) {
    yaml += keys[rng() % keys.size()] + ": " + random_value(rng) + "\n";
  }
  if (rng() % 10 == 0) yaml.insert(rng() % (yaml.size() + 1), std::string(1, static_cast<char>(rng() % 256)));
  return yaml;
}

TEST(Fuzz, GeneratedStudyFilesNeverCrashTheServiceOrCorruptTheStore) {
  const std::string path = (std::filesystem::temp_directory_path() / ("fuzz-" + std::to_string(getpid()) + ".db")).string();
  std::filesystem::remove(path);
  std::mt19937_64 rng(20261201);
  int accepted = 0;
  {
    study::StudyStore store(path);
    NullOutbox out;
    Coordinator coordinator(store, out, CoordinatorOptions{}, [](const std::string&) {}, [](const std::string&) {});
    for (int i = 0; i < 400; ++i) {
      domain::StudyCommand c;
      c.client_id = "fuzz";
      c.correlation_id = static_cast<std::uint64_t>(i + 1);
      c.kind = domain::CommandKind::kSubmit;
      const std::string yaml = random_study(rng);
      c.study_yaml = yaml.substr(0, 4000);
      c.source_name = "fuzz.yaml";
      ASSERT_NO_THROW(coordinator.handle_command(c, 1000.0 + i)) << yaml;
      ASSERT_EQ(out.replies.size(), static_cast<std::size_t>(i + 1));
      const auto& reply = out.replies.back();
      if (reply.ok) ++accepted;
      else EXPECT_FALSE(reply.message.empty()) << yaml;
      coordinator.tick(1000.0 + i);
    }
    EXPECT_EQ(coordinator.studies(), accepted);
    EXPECT_EQ(static_cast<int>(store.load_all().size()), accepted);  // nothing refused was stored
  }
  // The store still opens, and a restarted service resumes every accepted study.
  study::StudyStore store(path);
  NullOutbox out;
  Coordinator restarted(store, out, CoordinatorOptions{}, [](const std::string&) {}, [](const std::string&) {});
  ASSERT_NO_THROW(restarted.resume_from_store(5000.0));
  EXPECT_EQ(restarted.studies(), accepted);
  RecordProperty("accepted", accepted);
  std::printf("fuzz: %d of 400 generated study files accepted\n", accepted);
  EXPECT_GT(accepted, 0) << "the generator never produced a valid study: the fuzz proves little";
  EXPECT_LT(accepted, 400) << "the generator never produced an invalid study";
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(path + suffix);
}

}  // namespace
}  // namespace cpgmatch::service
