// The workers the optimizer service knows: who is live, how many slots each offers, what each holds, and
// which are on probation. No studies and no DDS here: the Coordinator decides what to give them.
//
// A slot count is a claim, not a right: a worker whose lease expired (it took a candidate and never
// answered in time) is on probation, with at most one candidate at a time, until a report of its own
// arrives for an attempt it was issued. Probation is kept by id, so leaving and rejoining the domain does
// not clear it.
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace cpgmatch::service {

struct PoolWorker {
  std::string id;
  std::uint64_t key = 0;
  int slots = 0;
  bool hardware = false;   // announced as a hardware worker
  bool accepting = true;
  std::string status;      // why it does not accept, as it announced
  double last_seen_s = 0.0;
  std::set<std::pair<int, int>> assigned;  // (study, trial)
};

// What one announcement changed.
struct AnnouncementEffect {
  bool joined = false;            // a worker the pool did not have
  bool accepts_again = false;     // it had announced that it does not accept, and now does
  bool availability_changed = false;  // accepting or its status changed
};

class WorkerPool {
 public:
  // Takes a (checked) announcement: adds the worker or refreshes it.
  AnnouncementEffect announce(const std::string& id, std::uint64_t key, int slots, bool hardware, bool accepting,
                              const std::string& status, double now_s);
  // Removes a worker; returns what it held (for re-issue). Empty when it was not there.
  std::set<std::pair<int, int>> remove(const std::string& id);
  // Workers not heard from for longer than `timeout_s`.
  std::vector<std::string> silent(double now_s, double timeout_s) const;
  // The worker with this key (the workers topic's), or nullptr.
  const PoolWorker* by_key(std::uint64_t key) const;
  PoolWorker* find(const std::string& id);
  const PoolWorker* find(const std::string& id) const;

  void assign(const std::string& id, int study_id, int trial_id);
  void release(const std::string& id, int study_id, int trial_id);  // no-op for a worker no longer here

  // Free slots it may be given now: its announced slots, or one while on probation, minus what it holds.
  int slots_free(const PoolWorker& w) const;
  // Free slots of one kind, one entry per slot, spread across workers (most free first); workers on
  // probation only after every worker in good standing.
  std::vector<PoolWorker*> free_slots(bool hardware);

  // Puts a worker on probation; true when it was not on it yet.
  bool put_on_probation(const std::string& id) { return probation_.insert(id).second; }
  // Ends a worker's probation; true when it was on it.
  bool end_probation(const std::string& id) { return probation_.erase(id) > 0; }
  bool on_probation(const std::string& id) const { return probation_.count(id) > 0; }

  bool has_hardware() const;
  bool has_simulation() const;
  int size() const { return static_cast<int>(workers_.size()); }
  const std::map<std::string, PoolWorker>& all() const { return workers_; }

 private:
  std::map<std::string, PoolWorker> workers_;
  std::set<std::string> probation_;
};

}  // namespace cpgmatch::service
