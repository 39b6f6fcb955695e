// The transport layer on a real DDS domain (in one process; the process-level tests are in
// tests/integration). Each test uses its own domain id so that ctest -j runs do not cross-talk.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>
#include <vector>

#include "cpgmatch/dds/convert.hpp"
#include "cpgmatch/domain/report_json.hpp"
#include "cpgmatch/dds/participant.hpp"
#include "cpgmatch/dds/security.hpp"
#include "cpgmatch/dds/worker_filter.hpp"
#include "cpgmatch_msgsPubSubTypes.h"

#include <openssl/evp.h>
#include <openssl/x509.h>
#include "../support/morti_legs.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch::dds {
namespace {

using namespace std::chrono_literals;

template <class T>
struct Inbox {
  std::mutex mutex;
  std::vector<T> samples;
  void push(const T& s) {
    std::lock_guard<std::mutex> lock(mutex);
    samples.push_back(s);
  }
  std::size_t size() {
    std::lock_guard<std::mutex> lock(mutex);
    return samples.size();
  }
  bool wait_for(std::size_t n, std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (size() < n && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(5ms);
    return size() >= n;
  }
};

msg::Candidate candidate(std::uint32_t trial, const std::string& worker) {
  msg::Candidate c;
  c.study_id(1);
  c.trial_id(trial);
  c.worker_id(worker);
  c.parameters(to_wire({{"frequency", 1.0}, {"hip_amplitude", 0.4}}));
  return c;
}

TEST(Transport, ContentFilterDeliversOnlyTheWorkersOwnCandidates) {
  Participant optimizer(ParticipantConfig::basic(35, "test-optimizer", true));
  Participant worker(ParticipantConfig::basic(35, "test-worker", true));
  Inbox<msg::Candidate> inbox;
  Reader<msg::Candidate> reader(worker, "candidates_for_a", "worker_id = %0", {"'a'"},
                                [&](const msg::Candidate& c) { inbox.push(c); });
  Writer<msg::Candidate> writer(optimizer);
  ASSERT_TRUE(writer.matched().wait_for(1, 10s));
  for (std::uint32_t i = 0; i < 6; ++i) ASSERT_TRUE(writer.write(candidate(i, i % 2 ? "b" : "a")));
  ASSERT_TRUE(inbox.wait_for(3, 10s));
  std::this_thread::sleep_for(200ms);  // anything for 'b' would have arrived by now
  std::lock_guard<std::mutex> lock(inbox.mutex);
  ASSERT_EQ(inbox.samples.size(), 3u);
  for (const auto& c : inbox.samples) {
    EXPECT_EQ(c.worker_id().to_string(), "a");
    EXPECT_EQ(from_wire(c.parameters()).at("hip_amplitude"), 0.4);
  }
}

TEST(Transport, WorkerFilterReadsTheSerializedWorkerId) {
  // The filter reads the worker id at a fixed place in the CDR; the generated serializer decides that place.
  msg::CandidatePubSubType type;
  for (const std::string& id : std::vector<std::string>{"w", "node-17/slot", std::string(63, 'x')}) {
    msg::Candidate c = candidate(12, id);
    c.store_id(0x0123456789abcdefULL);
    c.attempt(3);
    eprosima::fastrtps::rtps::SerializedPayload_t payload(type.getSerializedSizeProvider(&c)());
    ASSERT_TRUE(type.serialize(&c, &payload));
    std::string read;
    ASSERT_TRUE(candidate_worker_id(payload.data, payload.length, read)) << id;
    EXPECT_EQ(read, id);
    // Cut inside the id, or before it: not readable (the filter then lets the sample through).
    const std::size_t cut = 24 + id.size() / 2;
    EXPECT_FALSE(candidate_worker_id(payload.data, cut, read)) << id;
    EXPECT_FALSE(candidate_worker_id(payload.data, 20, read));
  }
  std::string read;
  EXPECT_FALSE(candidate_worker_id(nullptr, 0, read));  // a key-only sample's empty payload
}

TEST(Transport, WorkerIdFilterSendsEachWorkerItsOwnCandidatesAndDisposesOnly) {
  // Domain 44, not 35: ctest -j runs this beside ContentFilterDeliversOnlyTheWorkersOwnCandidates, and on one
  // domain each test's readers heard the other's six candidates (CI, stop 37).
  Participant optimizer(ParticipantConfig::basic(44, "test-optimizer", true));
  Participant worker_a(ParticipantConfig::basic(44, "test-worker-a", true));
  Participant worker_b(ParticipantConfig::basic(44, "test-worker-b", true));
  Inbox<msg::Candidate> got_a, got_b, gone_a, gone_b;
  using To = Reader<msg::Candidate>::AddressedToWorker;
  Reader<msg::Candidate> reader_a(
      worker_a, To{"a"}, [&](const msg::Candidate& c) { got_a.push(c); },
      [&](const msg::Candidate& key, InstanceGone g) { if (g.disposed) gone_a.push(key); });
  Reader<msg::Candidate> reader_b(
      worker_b, To{"b"}, [&](const msg::Candidate& c) { got_b.push(c); },
      [&](const msg::Candidate& key, InstanceGone g) { if (g.disposed) gone_b.push(key); });
  Writer<msg::Candidate> writer(optimizer);
  ASSERT_TRUE(writer.matched().wait_for(2, 10s));
  for (std::uint32_t i = 0; i < 6; ++i) ASSERT_TRUE(writer.write(candidate(i, i % 2 ? "b" : "a")));
  ASSERT_TRUE(got_a.wait_for(3, 10s));
  ASSERT_TRUE(got_b.wait_for(3, 10s));
  // Trial 0 was a's; re-issued to b (same instance, as after a lost worker), then retired: the dispose is
  // b's only. A key-only sample carries no worker id, so a reader-side filter could not tell: had the
  // writer not filtered it, a (which knows the instance) would hear the dispose too.
  msg::Candidate reissued = candidate(0, "b");
  reissued.attempt(1);
  ASSERT_TRUE(writer.write(reissued));
  ASSERT_TRUE(got_b.wait_for(4, 10s));
  ASSERT_TRUE(writer.unregister(reissued));
  ASSERT_TRUE(writer.unregister(candidate(2, "a")));  // a's own: a hears it
  ASSERT_TRUE(gone_b.wait_for(1, 10s));
  ASSERT_TRUE(gone_a.wait_for(1, 10s));
  std::this_thread::sleep_for(300ms);  // anything misaddressed would have arrived by now
  std::scoped_lock lock(got_a.mutex, got_b.mutex, gone_a.mutex, gone_b.mutex);
  ASSERT_EQ(got_a.samples.size(), 3u);
  for (const auto& c : got_a.samples) EXPECT_EQ(c.worker_id().to_string(), "a");
  ASSERT_EQ(got_b.samples.size(), 4u);
  for (const auto& c : got_b.samples) EXPECT_EQ(c.worker_id().to_string(), "b");
  ASSERT_EQ(gone_b.samples.size(), 1u);
  EXPECT_EQ(gone_b.samples[0].trial_id(), 0u);
  ASSERT_EQ(gone_a.samples.size(), 1u);
  EXPECT_EQ(gone_a.samples[0].trial_id(), 2u);
}

TEST(Transport, LateReaderGetsTransientLocalStatePerInstance) {
  Participant optimizer(ParticipantConfig::basic(36, "test-optimizer", true));
  Writer<msg::StudyState> writer(optimizer);
  for (std::uint32_t study = 1; study <= 20; ++study) {  // more than Fast DDS's default of 10 instances
    msg::StudyState s;
    s.study_id(study);
    s.completed(study * 2);
    ASSERT_TRUE(writer.write(s));
    s.completed(study * 3);  // the newer sample replaces the older one
    ASSERT_TRUE(writer.write(s));
  }
  Participant client(ParticipantConfig::basic(36, "test-client", true));
  Inbox<msg::StudyState> inbox;
  Reader<msg::StudyState> reader(client, [&](const msg::StudyState& s) { inbox.push(s); });
  ASSERT_TRUE(inbox.wait_for(20, 10s));
  std::this_thread::sleep_for(100ms);
  std::lock_guard<std::mutex> lock(inbox.mutex);
  ASSERT_EQ(inbox.samples.size(), 20u);
  for (const auto& s : inbox.samples) EXPECT_EQ(s.completed(), s.study_id() * 3);
}

TEST(Transport, ReaderHearsWhenAnInstanceIsUnregistered) {
  Participant a(ParticipantConfig::basic(37, "test-worker", true));
  Participant b(ParticipantConfig::basic(37, "test-optimizer", true));
  Inbox<msg::WorkerAnnouncement> alive;
  Inbox<msg::WorkerAnnouncement> gone;
  Reader<msg::WorkerAnnouncement> reader(
      b, [&](const msg::WorkerAnnouncement& w) { alive.push(w); },
      [&](const msg::WorkerAnnouncement& key, InstanceGone) { gone.push(key); });
  Writer<msg::WorkerAnnouncement> writer(a);
  msg::WorkerAnnouncement w;
  w.worker_id("w7");
  w.worker_key(worker_key("w7"));
  w.slots(3);
  ASSERT_TRUE(writer.matched().wait_for(1, 10s));
  ASSERT_TRUE(writer.write(w));
  ASSERT_TRUE(alive.wait_for(1, 10s));
  ASSERT_TRUE(writer.unregister(w));
  ASSERT_TRUE(gone.wait_for(1, 10s));
  std::lock_guard<std::mutex> lock(gone.mutex);
  EXPECT_EQ(gone.samples[0].worker_key(), worker_key("w7"));
  EXPECT_EQ(gone.samples[0].worker_id().to_string(), "w7");
}

TEST(Convert, TheDomainChecksParametersAndReports) {
  EXPECT_FALSE(domain::check_parameters({{"frequency", 1.0}}).has_value());
  EXPECT_TRUE(domain::check_parameters({{"frequency", std::nan("")}}).has_value());
  EXPECT_TRUE(domain::check_parameters({{"no_such_parameter", 1.0}}).has_value());
  EXPECT_TRUE(domain::check_parameters({}).has_value());
  domain::RolloutReport r;
  r.worker_id = "w";
  r.summary.cost = 1.0;
  r.summary.distance_m = 0.5;
  EXPECT_FALSE(domain::check_report(r).has_value());
  r.summary.cost = std::nan("");
  EXPECT_TRUE(domain::check_report(r).has_value());
  for (const auto outcome : {domain::Outcome::kRefused, domain::Outcome::kPlantFault, domain::Outcome::kDiverged,
                             domain::Outcome::kError}) {
    r.outcome = outcome;
    EXPECT_FALSE(domain::check_report(r).has_value()) << domain::to_string(outcome);  // its cost is not looked at
  }
  r.outcome = domain::Outcome::kFell;
  r.summary.cost = 3.0;
  EXPECT_FALSE(domain::check_report(r).has_value());
  r.worker_id.clear();
  EXPECT_TRUE(domain::check_report(r).has_value());
}

TEST(Convert, TheWireRefusesWhatTheDomainCannotHold) {
  msg::RolloutReport r;
  r.worker_id("w");
  r.ok(true);
  EXPECT_NO_THROW(from_wire(r));
  r.ok(false);
  EXPECT_THROW(from_wire(r), WireError);  // ok = false contradicts the (default) outcome completed
  for (const auto outcome : {msg::OUTCOME_REFUSED, msg::OUTCOME_PLANT_FAULT, msg::OUTCOME_DIVERGED, msg::OUTCOME_ERROR}) {
    r.outcome(outcome);
    EXPECT_NO_THROW(from_wire(r)) << static_cast<int>(outcome);
  }
  r.ok(true);
  EXPECT_THROW(from_wire(r), WireError);  // a rollout that ran cannot have been refused
  r.outcome(msg::OUTCOME_FELL);
  EXPECT_THROW(from_wire(r), WireError);  // outcome fell, but fell = false
  r.fell(true);
  EXPECT_EQ(from_wire(r).outcome, domain::Outcome::kFell);
  r.outcome(static_cast<msg::RolloutOutcome>(17));
  try {
    from_wire(r);
    ADD_FAILURE() << "an outcome of 17 was taken";
  } catch (const WireError& e) {
    EXPECT_NE(std::string(e.what()).find("outcome"), std::string::npos) << e.what();  // names the field
  }
  r.outcome(msg::OUTCOME_FELL);
  r.trial_id(0x80000000u);  // no id this service issues: not wrapped into a negative trial
  EXPECT_THROW(from_wire(r), WireError);

  msg::Candidate c;
  msg::ParameterValue v;
  v.name("frequency");
  v.value(1.0);
  c.parameters({v, v});
  EXPECT_THROW(from_wire(c), WireError);  // a name twice: a map cannot hold it, and no optimizer sends it
  c.parameters({v});
  EXPECT_EQ(from_wire(c).parameters.at("frequency"), 1.0);

  msg::StudyCommand command;
  command.kind(static_cast<msg::CommandKind>(9));
  EXPECT_THROW(from_wire(command), WireError);
}

TEST(Convert, EveryDomainValueSurvivesTheWire) {
  domain::RolloutReport r;
  r.id = domain::AttemptId{0xabcdef0123456789ull, 3, 41, 2};
  r.worker_id = "node12/1";
  r.worker_kind = domain::WorkerKind::kHardware;
  r.outcome = domain::Outcome::kFell;
  r.summary.cost = 17.5;
  r.summary.terms = CostTerms{0.1, 0.2, 0.3, 0.4, 0.5};
  r.summary.feedback = FeedbackFractions{0.01, 0.02, 0.03, 0.04};
  r.summary.normalized_torque = 6.5;
  r.summary.summed_torque_nm = 1.9;
  r.summary.fall_time_s = 4.25;
  r.summary.distance_m = 1.1;
  r.summary.mean_speed_mps = 0.3;
  r.wall_time_s = 0.23;
  r.loop = domain::LoopTiming{12.0, 40.0, 90.0, 3};
  r.summary.energy.electrical_cost_of_transport = 4.5;
  r.summary.energy.signed_torque_per_speed = 11.0;
  r.summary.energy.positive_work_j_per_m = 28.0;
  r.summary.energy.hip = r.summary.energy.knee = PerLeg<JointEnergy>(test::kNumLegs);
  for (int leg = 0; leg < kNumLegs; ++leg) {
    r.summary.energy.hip[leg] = {1.0 + leg, 2.0 + leg, 3.0 + leg, -0.1 * leg};
    r.summary.energy.knee[leg] = {5.0 + leg, 6.0 + leg, 7.0 + leg, -0.5 - leg};
  }
  const domain::RolloutReport back = from_wire(to_wire(r));
  EXPECT_EQ(domain::to_json(back), domain::to_json(r));
  EXPECT_EQ(back.id.store_id, r.id.store_id);
  EXPECT_EQ(back.id.attempt, 2);
  EXPECT_FALSE(back.synthetic);
  // Four legs also fill the arrays a reader built before leg_energy reads.
  EXPECT_EQ(to_wire(r).knee_electrical_j()[3], 7.0 + 3);
  // Six legs (a hexapod, issue 31): every leg's energy crosses in leg_energy; the four-leg arrays say "not
  // measured" (NaN) rather than four legs of six.
  domain::RolloutReport hexapod = r;
  hexapod.summary.energy.hip = hexapod.summary.energy.knee = PerLeg<JointEnergy>(6);
  for (std::size_t leg = 0; leg < 6; ++leg) {
    hexapod.summary.energy.hip[leg] = {1.0 + leg, 2.0 + leg, 3.0 + leg, -0.1 * leg};
    hexapod.summary.energy.knee[leg] = {5.0 + leg, 6.0 + leg, 7.0 + leg, -0.5 - leg};
  }
  const msg::RolloutReport hexapod_wire = to_wire(hexapod);
  EXPECT_EQ(hexapod_wire.leg_energy().size(), 6u);
  EXPECT_TRUE(std::isnan(hexapod_wire.hip_positive_work_j()[0]));
  EXPECT_EQ(domain::to_json(from_wire(hexapod_wire)), domain::to_json(hexapod));
  EXPECT_EQ(from_wire(hexapod_wire).summary.energy.knee[5].electrical_j, 12.0);
  // A writer built before leg_energy (the arrays only): read from the arrays, four legs.
  msg::RolloutReport old_writer = to_wire(r);
  old_writer.leg_energy().clear();
  EXPECT_EQ(domain::to_json(from_wire(old_writer)), domain::to_json(r));
  // A service benchmark's synthetic report keeps its mark across the wire (issue 32).
  domain::RolloutReport fake = r;
  fake.worker_kind = domain::WorkerKind::kSimulation;
  fake.outcome = domain::Outcome::kCompleted;
  fake.synthetic = true;
  EXPECT_TRUE(to_wire(fake).synthetic());
  EXPECT_TRUE(from_wire(to_wire(fake)).synthetic);

  domain::Candidate c;
  c.id = r.id;
  c.worker_id = "w";
  c.lease_s = 60.0;
  c.spec_key = 0x1122334455667788ull;
  c.rollout = domain::RolloutConditions{10.0, 10.0, "rough:0.01", 99};
  c.parameters = {{"frequency", 1.2}, {"duty_factor", 0.6}};
  const domain::Candidate cb = from_wire(to_wire(c));
  EXPECT_EQ(cb.parameters, c.parameters);
  EXPECT_EQ(cb.spec_key, c.spec_key);
  EXPECT_EQ(cb.rollout.terrain, "rough:0.01");
  EXPECT_EQ(cb.rollout.seed, 99u);
  EXPECT_EQ(cb.id.trial_id, 41);

  domain::StudyState st;
  st.study_id = 7;
  st.name = "paper";
  st.status = domain::StudyStatus::kPaused;
  st.budget = 150;
  st.completed = 20;
  st.best_cost = 2.5;
  st.best_params = {{"frequency", 1.0}};
  st.has_recommendation = true;
  st.recommendation = domain::Recommendation{4, 2.7, {{"frequency", 1.1}}};
  st.message = "waiting";
  // A hexapod's legs and its own search space cross by name (issue 31): what a viewer names its values by.
  st.leg_names = {"L1", "R1", "L2", "R2", "L3", "R3"};
  st.search_space = {{"hip_amplitude", 0.1, 0.45, false, "rad"}, {"overswing", 0.0, 0.5, false, "1"}};
  const domain::StudyState sb = from_wire(to_wire(st));
  EXPECT_EQ(sb.leg_names, st.leg_names);
  ASSERT_EQ(sb.search_space.size(), 2u);
  EXPECT_EQ(sb.search_space[0].unit, "rad");
  EXPECT_DOUBLE_EQ(sb.search_space[0].high, 0.45);
  EXPECT_EQ(domain::to_json(sb), domain::to_json(st));
  domain::TrialRecord record;
  record.report = r;
  record.leg_names = st.leg_names;
  EXPECT_EQ(from_wire(to_wire(record)).leg_names, st.leg_names);
}

TEST(Convert, AWorkerIdBelongsToItsCertificatesCommonNameOrItsInstances) {
  EXPECT_TRUE(worker_id_belongs_to("node12", "node12"));
  EXPECT_TRUE(worker_id_belongs_to("node12/1", "node12"));
  EXPECT_TRUE(worker_id_belongs_to("worker/local-7-0", "worker"));
  EXPECT_FALSE(worker_id_belongs_to("node123", "node12"));  // a prefix is not enough
  EXPECT_FALSE(worker_id_belongs_to("node12/", "node12"));  // an empty suffix is no instance
  EXPECT_FALSE(worker_id_belongs_to("node1", "node12"));
  EXPECT_FALSE(worker_id_belongs_to("other/node12", "node12"));
  EXPECT_FALSE(worker_id_belongs_to("node12", ""));  // no identity owns nothing
  EXPECT_FALSE(worker_id_belongs_to("", "node12"));
}

// The GUID prefix Fast DDS's PKI-DH gives a participant whose certificate subject is `subject` (bit 0 set,
// bits 1..47 the first 47 bits of SHA-256 of the DER subject; the rest is left arbitrary here).
void guid_prefix_for(const char* cn, unsigned char (&prefix)[12]) {
  X509_NAME* name = X509_NAME_new();
  X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_UTF8, reinterpret_cast<const unsigned char*>(cn), -1, -1, 0);
  unsigned char md[32];
  unsigned int length = 0;
  X509_NAME_digest(name, EVP_sha256(), md, &length);
  X509_NAME_free(name);
  for (unsigned char& b : prefix) b = 0x5a;
  prefix[0] = static_cast<unsigned char>(0x80 | (md[0] >> 1));
  for (int i = 1; i < 6; ++i) prefix[i] = static_cast<unsigned char>((md[i - 1] << 7) | (md[i] >> 1));
}

TEST(Security, AnAnnouncedSubjectNamesTheParticipantOnlyIfItsGuidWasDerivedFromIt) {
  unsigned char worker[12], mallory[12];
  guid_prefix_for("worker", worker);
  guid_prefix_for("mallory", mallory);
  std::string why;
  EXPECT_EQ(authenticated_common_name("/CN=worker", worker, why), std::optional<std::string>("worker")) << why;
  // mallory's participant announcing worker's subject in its IdentityToken: refused, with the reason.
  EXPECT_FALSE(authenticated_common_name("/CN=worker", mallory, why).has_value());
  EXPECT_NE(why.find("not derived from the subject '/CN=worker'"), std::string::npos) << why;
  unsigned char no_security[12] = {0x01, 0x0f, 0x12, 0x34};  // an ordinary (unauthenticated) GUID prefix
  EXPECT_FALSE(authenticated_common_name("/CN=worker", no_security, why).has_value());
  for (const char* bad : {"", "CN=worker", "/CN=", "/O=cpgmatch", "/noequals"}) {
    EXPECT_FALSE(authenticated_common_name(bad, worker, why).has_value()) << bad;
  }
}

}  // namespace
}  // namespace cpgmatch::dds
