// The transport layer on a real DDS domain (in one process; the process-level tests are in
// tests/integration). Each test uses its own domain id so that ctest -j runs do not cross-talk.
#include <gtest/gtest.h>

#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "cpgmatch/dds/convert.hpp"
#include "cpgmatch/dds/participant.hpp"
#include "cpgmatch/dds/security.hpp"

#include <openssl/evp.h>
#include <openssl/x509.h>

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

TEST(Convert, RejectsBadParametersAndReports) {
  EXPECT_FALSE(check_parameters(to_wire({{"frequency", 1.0}})).has_value());
  EXPECT_TRUE(check_parameters(to_wire({{"frequency", std::nan("")}})).has_value());
  EXPECT_TRUE(check_parameters(to_wire({{"no_such_parameter", 1.0}})).has_value());
  EXPECT_TRUE(check_parameters({}).has_value());
  msg::RolloutReport r;
  r.worker_id("w");
  r.ok(true);
  EXPECT_FALSE(check_report(r).has_value());
  r.cost(std::nan(""));
  EXPECT_TRUE(check_report(r).has_value());
  r.ok(false);
  EXPECT_TRUE(check_report(r).has_value());  // ok = false contradicts the (default) outcome completed
  for (const auto outcome : {msg::OUTCOME_REFUSED, msg::OUTCOME_PLANT_FAULT, msg::OUTCOME_DIVERGED, msg::OUTCOME_ERROR}) {
    r.outcome(outcome);
    EXPECT_FALSE(check_report(r).has_value()) << to_string(outcome);  // a failed rollout's cost is not looked at
  }
  r.ok(true);
  EXPECT_TRUE(check_report(r).has_value());  // a rollout that ran cannot have been refused
  r.outcome(msg::OUTCOME_FELL);
  r.cost(3.0);
  EXPECT_TRUE(check_report(r).has_value());  // outcome fell, but fell = false
  r.fell(true);
  EXPECT_FALSE(check_report(r).has_value());
  r.outcome(static_cast<msg::RolloutOutcome>(17));
  EXPECT_TRUE(check_report(r).has_value());  // not an outcome at all
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
