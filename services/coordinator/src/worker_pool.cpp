#include "cpgmatch/service/worker_pool.hpp"

#include <algorithm>

namespace cpgmatch::service {

AnnouncementEffect WorkerPool::announce(const std::string& id, std::uint64_t key, int slots, bool hardware,
                                        bool accepting, const std::string& status, double now_s) {
  auto [it, is_new] = workers_.try_emplace(id);
  PoolWorker& w = it->second;
  AnnouncementEffect effect;
  effect.joined = is_new;
  effect.accepts_again = !is_new && accepting && !w.accepting;
  effect.availability_changed = !is_new && (accepting != w.accepting || status != w.status);
  w.id = id;
  w.key = key;
  w.slots = slots;
  w.hardware = hardware;
  w.accepting = accepting;
  w.status = status;
  w.last_seen_s = now_s;
  return effect;
}

std::set<std::pair<int, int>> WorkerPool::remove(const std::string& id) {
  const auto it = workers_.find(id);
  if (it == workers_.end()) return {};
  auto held = std::move(it->second.assigned);
  workers_.erase(it);
  return held;
}

std::vector<std::string> WorkerPool::silent(double now_s, double timeout_s) const {
  std::vector<std::string> out;
  for (const auto& [id, w] : workers_) {
    if (now_s - w.last_seen_s > timeout_s) out.push_back(id);
  }
  return out;
}

const PoolWorker* WorkerPool::by_key(std::uint64_t key) const {
  for (const auto& [id, w] : workers_) {
    if (w.key == key) return &w;
  }
  return nullptr;
}

PoolWorker* WorkerPool::find(const std::string& id) {
  const auto it = workers_.find(id);
  return it == workers_.end() ? nullptr : &it->second;
}

const PoolWorker* WorkerPool::find(const std::string& id) const {
  const auto it = workers_.find(id);
  return it == workers_.end() ? nullptr : &it->second;
}

void WorkerPool::assign(const std::string& id, int study_id, int trial_id) {
  if (PoolWorker* w = find(id)) w->assigned.insert({study_id, trial_id});
}

void WorkerPool::release(const std::string& id, int study_id, int trial_id) {
  if (PoolWorker* w = find(id)) w->assigned.erase({study_id, trial_id});
}

int WorkerPool::slots_free(const PoolWorker& w) const {
  const int usable = on_probation(w.id) ? std::min(w.slots, 1) : w.slots;
  return std::max(0, usable - static_cast<int>(w.assigned.size()));
}

std::vector<PoolWorker*> WorkerPool::free_slots(bool hardware) {
  std::vector<PoolWorker*> ready;
  std::map<PoolWorker*, int> free;
  for (auto& [id, w] : workers_) {
    if (w.hardware == hardware && w.accepting && slots_free(w) > 0) {
      ready.push_back(&w);
      free[&w] = slots_free(w);
    }
  }
  // Workers on probation come last: work goes to one only when no worker in good standing has a slot.
  // Otherwise the same never-answering worker would take the same re-issued trial lease after lease (seen
  // in deploy.forged_identity: the study's last trial stalled until the rogue left).
  std::stable_partition(ready.begin(), ready.end(), [this](const PoolWorker* w) { return !on_probation(w->id); });
  std::vector<PoolWorker*> slots;
  for (const bool probation : {false, true}) {
    bool any = true;
    while (any) {
      any = false;
      for (PoolWorker* w : ready) {
        if (on_probation(w->id) == probation && free[w] > 0) {
          slots.push_back(w);
          --free[w];
          any = true;
        }
      }
    }
  }
  return slots;
}

bool WorkerPool::has_hardware() const {
  return std::any_of(workers_.begin(), workers_.end(), [](const auto& kv) { return kv.second.hardware; });
}

bool WorkerPool::has_simulation() const {
  return std::any_of(workers_.begin(), workers_.end(), [](const auto& kv) { return !kv.second.hardware; });
}

}  // namespace cpgmatch::service
