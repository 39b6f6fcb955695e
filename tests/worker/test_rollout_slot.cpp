// A worker slot's kept rollout process (issue 32): a rollout computes the same bits whether it runs in a
// fresh process or as the first or the tenth in a kept one (ODE's process-wide state included), and a
// process that crashes, hangs or answers with garbage costs exactly that candidate, never the next one.
// Real rollouts through the real cpgmatch-sim-worker (short ones: 0.3 s entrained, 0.5 s scored).
#include <signal.h>
#include <stdlib.h>

#include <chrono>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cpgmatch/command_objective.hpp"
#include "cpgmatch/domain/report_json.hpp"
#include "rollout_request.hpp"
#include "rollout_slot.hpp"
#include "spec_cache.hpp"

namespace cpgmatch::worker {
namespace {

const std::string kWorker = CPGMATCH_SIM_WORKER;

std::shared_ptr<const study::StudySpec> spec_of(const std::string& yaml) {
  return std::make_shared<const study::StudySpec>(
      study::StudySpec::resolve(yaml, "test.yaml", study::SpecDefaults::shipped()));
}

const std::shared_ptr<const study::StudySpec> kPlain = spec_of("name: plain\n");
const std::shared_ptr<const study::StudySpec> kStiff = spec_of("name: stiff\nmodel: {knee_spring: {stiffness_nm_per_rad: 20}}\n");

SlotOptions slot_options() {
  SlotOptions o;
  o.worker_id = "w1";
  o.rollout_command = {kWorker, "--serve-rollouts"};
  o.find_spec = [](std::uint64_t key) -> SpecLookup {
    for (const auto& s : {kPlain, kStiff}) {
      if (s->key() == key) return {s, ""};
    }
    return {nullptr, "unknown spec"};
  };
  return o;
}

// Candidate `trial` of a small, varied set: gaits, terrains (rough ground draws from the seed) and specs.
domain::Candidate candidate(int trial, std::uint64_t seed = 0) {
  static const std::vector<std::map<std::string, double>> gaits = {
      {{"hip_offset", -0.1934}, {"hip_amplitude", 0.3454}, {"knee_amplitude", 0.5236}, {"frequency", 1.0},
       {"duty_factor_front", 0.3}, {"duty_factor_hind", 0.75}, {"knee_phase_shift", 0.0}, {"overswing", 0.5}},
      {{"hip_offset", 0.1}, {"hip_amplitude", 0.5}, {"knee_amplitude", 0.9}, {"frequency", 1.7},
       {"duty_factor_front", 0.55}, {"duty_factor_hind", 0.45}, {"knee_phase_shift", 0.2}, {"overswing", 0.1}},
      {{"hip_offset", -0.4}, {"hip_amplitude", 0.65}, {"knee_amplitude", 0.2}, {"frequency", 2.6},
       {"duty_factor_front", 0.7}, {"duty_factor_hind", 0.25}, {"knee_phase_shift", 0.45}, {"overswing", 0.35}},
  };
  static const std::vector<std::string> terrains = {"flat", "rough:0.003", "step:0.01@0.5", "shift:-0.01@0.4"};
  domain::Candidate c;
  c.id = domain::AttemptId{77, 1, trial, 0};
  c.worker_id = "w1";
  c.lease_s = 60.0;
  c.spec_key = (trial % 2 == 1 ? kStiff : kPlain)->key();
  c.parameters = gaits[static_cast<std::size_t>(trial) % gaits.size()];
  c.rollout = {0.3, 0.5, terrains[static_cast<std::size_t>(trial) % terrains.size()], seed ? seed : 100u + static_cast<std::uint64_t>(trial)};
  return c;
}

// What the store and the wire keep of a report, but for the time it took (a measurement of the machine).
std::string without_wall_time(domain::RolloutReport r) {
  r.wall_time_s = 0.0;
  return domain::to_json(r).dump();
}

// The candidate's report as a process of its own computes it (`--run-one`, the path before kept processes).
std::string fresh_process_report(const domain::Candidate& c) {
  const std::shared_ptr<const study::StudySpec> spec = slot_options().find_spec(c.spec_key).spec;
  const EvaluationOutcome out =
      run_command_objective("exec " + shell_quote(kWorker) + " --run-one", rollout_request(c, *spec).dump(), 120.0);
  EXPECT_TRUE(out.ok) << out.message;
  if (out.stdout_lines.size() < 2) return "no report";
  domain::RolloutReport r = domain::report_from_json(nlohmann::json::parse(out.stdout_lines[out.stdout_lines.size() - 2]));
  r.id = c.id;
  r.worker_id = "w1";
  r.worker_kind = domain::WorkerKind::kSimulation;
  return without_wall_time(r);
}

// Whether `pid` (a child of this process, not yet reaped) has died, waiting up to 10 s: /proc shows it as a
// zombie ('Z') until it is reaped.
bool wait_until_dead(pid_t pid) {
  for (int i = 0; i < 1000; ++i) {
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
    const std::size_t after_name = text.rfind(')');
    if (after_name == std::string::npos || text.substr(after_name + 2, 1) == "Z") return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : name_(name) { setenv(name, value.c_str(), 1); }
  ~ScopedEnv() { unsetenv(name_); }

 private:
  const char* name_;
};

TEST(RolloutSlot, EveryRolloutInAKeptProcessEqualsItsFreshProcessRunInAnyOrder) {
  constexpr int kCandidates = 6;
  std::vector<std::string> fresh;
  for (int t = 0; t < kCandidates; ++t) fresh.push_back(fresh_process_report(candidate(t)));
  // Candidates that measure different things, or the comparison below could not tell one from another.
  for (int a = 0; a < kCandidates; ++a) {
    for (int b = a + 1; b < kCandidates; ++b) EXPECT_NE(fresh[a], fresh[b]) << "candidates " << a << " and " << b;
  }
  // Each order in one kept process: forwards, backwards, and repeats (the same candidate first and last,
  // one twice in a row), across two specs held at once and every kind of ground.
  const std::vector<std::vector<int>> orders = {{0, 1, 2, 3, 4, 5}, {5, 4, 3, 2, 1, 0}, {2, 2, 0, 3, 5, 1, 4, 3, 0, 1, 2, 5}};
  for (const auto& order : orders) {
    RolloutSlot slot(slot_options());
    pid_t process = 0;
    for (std::size_t k = 0; k < order.size(); ++k) {
      const domain::RolloutReport r = slot.execute(candidate(order[k]));
      ASSERT_TRUE(r.ok()) << r.error;
      EXPECT_EQ(without_wall_time(r), fresh[static_cast<std::size_t>(order[k])])
          << "candidate " << order[k] << " as rollout " << k << " of its process";
      if (k == 0) process = slot.rollout_process_id();
      EXPECT_EQ(slot.rollout_process_id(), process) << "the process was not kept";
    }
  }
}

TEST(RolloutSlot, AProcessThatCrashesMidRolloutCostsThatCandidateOnly) {
  const ScopedEnv fault("CPGMATCH_TEST_ROLLOUT_FAULT", "abort:13");
  RolloutSlot slot(slot_options());
  ASSERT_TRUE(slot.execute(candidate(0)).ok());
  const pid_t before = slot.rollout_process_id();
  const domain::RolloutReport crashed = slot.execute(candidate(1, 13));
  EXPECT_FALSE(crashed.ok());
  EXPECT_EQ(crashed.outcome, domain::Outcome::kError);
  EXPECT_NE(crashed.error.find("killed by signal " + std::to_string(SIGABRT)), std::string::npos) << crashed.error;
  EXPECT_EQ(slot.rollout_process_id(), 0) << "the crashed process was not reaped";
  EXPECT_NE(kill(before, 0), 0) << "the crashed process is still there";
  // Its replacement starts before the next candidate arrives; that candidate runs in it (it is sent the
  // spec again) and measures what it always does.
  slot.prepare();
  const pid_t replacement = slot.rollout_process_id();
  EXPECT_NE(replacement, 0);
  EXPECT_NE(replacement, before);
  const domain::RolloutReport next = slot.execute(candidate(1));
  ASSERT_TRUE(next.ok()) << next.error;
  EXPECT_EQ(slot.rollout_process_id(), replacement);
  EXPECT_EQ(without_wall_time(next), fresh_process_report(candidate(1)));
}

TEST(RolloutSlot, AProcessThatHangsPastTheLeaseIsKilledAndReplaced) {
  const ScopedEnv fault("CPGMATCH_TEST_ROLLOUT_FAULT", "hang:13");
  RolloutSlot slot(slot_options());
  ASSERT_TRUE(slot.execute(candidate(0)).ok());
  const pid_t hung = slot.rollout_process_id();
  domain::Candidate c = candidate(1, 13);
  c.lease_s = 1.0;
  const domain::RolloutReport r = slot.execute(c);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.error.find("timed out after 1.0 s and was killed"), std::string::npos) << r.error;
  EXPECT_EQ(slot.rollout_process_id(), 0);
  EXPECT_NE(kill(hung, 0), 0) << "the hung process is still there";  // killed and reaped: no such pid
  EXPECT_TRUE(slot.execute(candidate(2)).ok());
}

TEST(RolloutSlot, GarbageOnTheAnswerStreamCostsThatCandidateAndTheProcess) {
  const ScopedEnv fault("CPGMATCH_TEST_ROLLOUT_FAULT", "garbage:13");
  RolloutSlot slot(slot_options());
  const domain::RolloutReport r = slot.execute(candidate(1, 13));
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.error.find("unreadable rollout output"), std::string::npos) << r.error;
  EXPECT_EQ(slot.rollout_process_id(), 0) << "a process out of step with its requests was kept";
  const domain::RolloutReport next = slot.execute(candidate(2));
  ASSERT_TRUE(next.ok()) << next.error;
  EXPECT_EQ(without_wall_time(next), fresh_process_report(candidate(2)));
}

TEST(RolloutSlot, AnOdeFailureIsADivergedRolloutAndTheNextCandidateGetsAFreshProcess) {
  const ScopedEnv fault("CPGMATCH_TEST_ROLLOUT_FAULT", "ode_failure:13");
  RolloutSlot slot(slot_options());
  const domain::RolloutReport diverged = slot.execute(candidate(1, 13));
  EXPECT_EQ(diverged.outcome, domain::Outcome::kDiverged);
  EXPECT_NE(diverged.error.find("simulation failed: ODE INTERNAL ERROR"), std::string::npos) << diverged.error;
  EXPECT_EQ(slot.rollout_process_id(), 0) << "the process that said it ends was not reaped";
  const domain::RolloutReport next = slot.execute(candidate(2));
  ASSERT_TRUE(next.ok()) << next.error;
  EXPECT_EQ(without_wall_time(next), fresh_process_report(candidate(2)));
}

TEST(RolloutSlot, AProcessKilledBetweenRolloutsIsReplacedWithoutFailingTheNextCandidate) {
  RolloutSlot slot(slot_options());
  ASSERT_TRUE(slot.execute(candidate(0)).ok());
  const pid_t killed = slot.rollout_process_id();
  ASSERT_GT(killed, 0);
  ASSERT_EQ(kill(killed, SIGKILL), 0);
  // Dead (a zombie until the slot reaps it) before the next candidate arrives: "between rollouts". One that
  // dies after the slot looked and before it read the request costs that candidate, as a crash does.
  ASSERT_TRUE(wait_until_dead(killed));
  const domain::RolloutReport next = slot.execute(candidate(0));
  ASSERT_TRUE(next.ok()) << next.error;
  EXPECT_NE(slot.rollout_process_id(), killed);
}

TEST(RolloutSlot, ARefusedCandidateLeavesTheProcessServing) {
  RolloutSlot slot(slot_options());
  ASSERT_TRUE(slot.execute(candidate(0)).ok());
  const pid_t process = slot.rollout_process_id();
  domain::Candidate c = candidate(1);
  c.spec_key = 12345;  // a spec the worker does not have: refused before any process sees it
  EXPECT_EQ(slot.execute(c).outcome, domain::Outcome::kRefused);
  EXPECT_TRUE(slot.execute(candidate(2)).ok());
  EXPECT_EQ(slot.rollout_process_id(), process);
}

TEST(RolloutSlot, FakeRolloutsStartNoProcess) {
  SlotOptions o = slot_options();
  o.fake_rollout_s = 0.0;
  RolloutSlot slot(o);
  slot.prepare();
  const domain::RolloutReport r = slot.execute(candidate(0));
  EXPECT_TRUE(r.ok()) << r.error;
  EXPECT_TRUE(r.synthetic);
  EXPECT_EQ(slot.rollout_process_id(), 0);
}

// The protocol itself: a process is sent a study's spec once, then only its key.
TEST(RolloutServer, HoldsASpecOnceSentAndAsksForOneItDoesNotHold) {
  LineProcess process({kWorker, "--serve-rollouts"});
  const auto deadline = LineProcess::Clock::now() + std::chrono::seconds(60);
  const domain::Candidate c = candidate(0);
  const auto answer = [&](bool with_spec) {
    const LineProcess::Reply reply = process.exchange(rollout_request(c, *kPlain, with_spec).dump(), deadline, 60.0);
    EXPECT_TRUE(reply.ok) << reply.failure;
    return nlohmann::json::parse(reply.ok ? reply.line : "{}");
  };
  EXPECT_EQ(answer(false), nlohmann::json({{"unknown_spec", study::spec_key_hex(kPlain->key())}}));
  const nlohmann::json first = answer(true);
  ASSERT_TRUE(first.contains("report")) << first.dump();
  const nlohmann::json again = answer(false);  // the key alone: it kept the parsed spec
  ASSERT_TRUE(again.contains("report")) << again.dump();
  EXPECT_EQ(again.at("report").at("cost"), first.at("report").at("cost"));
  // A malformed request is answered, and the process serves on.
  const LineProcess::Reply bad = process.exchange(R"({"params": {}})", deadline, 60.0);
  ASSERT_TRUE(bad.ok) << bad.failure;
  EXPECT_TRUE(nlohmann::json::parse(bad.line).contains("error")) << bad.line;
  EXPECT_TRUE(answer(false).contains("report"));
}

TEST(SpecCache, KeepsTheMostRecentlyUsedSpecsUpToItsCapacity) {
  SpecCache cache(2);
  const auto third = spec_of("name: third\n");
  cache.keep(kPlain);
  cache.keep(kStiff);
  EXPECT_EQ(cache.find(kPlain->key()), kPlain);  // used: now the stiff spec is the least recently used
  cache.keep(third);
  EXPECT_EQ(cache.size(), 2u);
  EXPECT_EQ(cache.find(kStiff->key()), nullptr);
  EXPECT_EQ(cache.find(kPlain->key()), kPlain);
  EXPECT_EQ(cache.find(third->key()), third);
}

}  // namespace
}  // namespace cpgmatch::worker
