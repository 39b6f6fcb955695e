// Where the coordinator's decisions go out: candidates, trial records, study states, command replies and
// study specs, as domain values. The DDS shell (services/optimizer_service) converts and writes them; tests
// record them.
#pragma once

#include <functional>
#include <vector>

#include "cpgmatch/domain/candidate.hpp"
#include "cpgmatch/domain/command.hpp"
#include "cpgmatch/domain/study_state.hpp"

namespace cpgmatch::service {

class Outbox {
 public:
  virtual ~Outbox() = default;
  virtual void send_candidate(const domain::Candidate& c) = 0;
  virtual void retire_candidate(const domain::Candidate& c) = 0;  // report received: drop it from the topic
  virtual void publish_trial(const domain::TrialRecord& t) = 0;
  // A finished study's record leaves the topic (its study and trial id are set; the store keeps the record).
  virtual void retire_trial(const domain::TrialRecord& t) = 0;
  virtual void publish_state(const domain::StudyState& s) = 0;
  virtual void reply(const domain::CommandReply& r) = 0;
  // An open study's spec on cpgmatch/study_specs, and its leaving once no open study uses it.
  virtual void publish_spec(const domain::SpecPublication&) {}
  virtual void retire_spec(const domain::SpecPublication&) {}
};

// Holds what the coordinator publishes while a store batch (study::StudyStore::Batch) is open, and
// passes it on, in order, once the batch has committed: a report is acknowledged (its candidate retired,
// its trial record published), a candidate sent or a command answered only after the store holds it, as
// when every write committed on its own. Not holding: passes everything straight on.
class DeferredOutbox final : public Outbox {
 public:
  explicit DeferredOutbox(Outbox& target) : target_(target) {}
  void hold() { holding_ = true; }
  // Sends everything held, in order, and stops holding.
  void release();
  // Drops everything held (the batch did not commit) and stops holding.
  void discard();
  std::size_t held() const { return held_.size(); }

  void send_candidate(const domain::Candidate& c) override { pass([c](Outbox& o) { o.send_candidate(c); }); }
  void retire_candidate(const domain::Candidate& c) override { pass([c](Outbox& o) { o.retire_candidate(c); }); }
  void publish_trial(const domain::TrialRecord& t) override { pass([t](Outbox& o) { o.publish_trial(t); }); }
  void retire_trial(const domain::TrialRecord& t) override { pass([t](Outbox& o) { o.retire_trial(t); }); }
  void publish_state(const domain::StudyState& s) override { pass([s](Outbox& o) { o.publish_state(s); }); }
  void reply(const domain::CommandReply& r) override { pass([r](Outbox& o) { o.reply(r); }); }
  void publish_spec(const domain::SpecPublication& s) override { pass([s](Outbox& o) { o.publish_spec(s); }); }
  void retire_spec(const domain::SpecPublication& s) override { pass([s](Outbox& o) { o.retire_spec(s); }); }

 private:
  void pass(std::function<void(Outbox&)> send) {
    if (holding_) held_.push_back(std::move(send));
    else send(target_);
  }
  Outbox& target_;
  bool holding_ = false;
  std::vector<std::function<void(Outbox&)>> held_;
};

}  // namespace cpgmatch::service
