// virtual backend: an in-process bus. Every endpoint opened with the same name sees the frames every
// other endpoint sends (not its own, like a SocketCAN socket without CAN_RAW_RECV_OWN_MSGS). For unit
// tests: it takes a mutex and its queues allocate.
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <vector>

#include <fmt/format.h>

#include "backends.hpp"

namespace cpgmatch::can::detail {
namespace {

// Frames an endpoint has not read yet beyond this are dropped (oldest first), like a full receive queue.
constexpr std::size_t kQueueCapacity = 4096;

class VirtualEndpoint;

struct Hub {
  std::mutex mutex;
  std::vector<VirtualEndpoint*> endpoints;
};

std::mutex g_registry_mutex;
std::map<std::string, std::weak_ptr<Hub>> g_registry;

std::shared_ptr<Hub> hub_named(const std::string& name) {
  std::lock_guard<std::mutex> lock(g_registry_mutex);
  auto& weak = g_registry[name];
  auto hub = weak.lock();
  if (!hub) {
    hub = std::make_shared<Hub>();
    weak = hub;
  }
  return hub;
}

class VirtualEndpoint final : public CanBus {
 public:
  explicit VirtualEndpoint(const BusUri& uri) : uri_(uri.text), hub_(hub_named(uri.name)) {
    std::lock_guard<std::mutex> lock(hub_->mutex);
    hub_->endpoints.push_back(this);
  }
  ~VirtualEndpoint() override {
    std::lock_guard<std::mutex> lock(hub_->mutex);
    std::erase(hub_->endpoints, this);
  }

  void send(const CanFrame& frame) override {
    if (auto problem = frame_problem(frame)) throw CanError(fmt::format("{}: cannot send {}: {}", uri_, to_string(frame), *problem));
    std::lock_guard<std::mutex> lock(hub_->mutex);
    for (VirtualEndpoint* endpoint : hub_->endpoints) {
      if (endpoint != this) endpoint->deliver(frame);
    }
    counters_.sent.fetch_add(1, std::memory_order_relaxed);
  }

  bool receive(CanFrame& out, std::chrono::nanoseconds timeout) override {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!arrived_.wait_for(lock, timeout, [&] { return !queue_.empty(); })) return false;
    out = queue_.front();
    queue_.pop_front();
    counters_.received.fetch_add(1, std::memory_order_relaxed);
    return true;
  }

  void set_filters(std::span<const CanFilter> filters) override {
    std::lock_guard<std::mutex> lock(mutex_);
    filter_.set(filters);
  }
  void set_error_frames(bool enabled) override {
    std::lock_guard<std::mutex> lock(mutex_);
    filter_.set_error_frames(enabled);
  }
  const std::string& uri() const override { return uri_; }
  BusCounters counters() const override { return counters_.snapshot(); }

 private:
  void deliver(const CanFrame& frame) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!filter_.accepts(frame)) {
        counters_.filtered_out.fetch_add(1, std::memory_order_relaxed);
        return;
      }
      if (queue_.size() >= kQueueCapacity) {
        queue_.pop_front();
        counters_.dropped.fetch_add(1, std::memory_order_relaxed);
      }
      queue_.push_back(frame);
    }
    arrived_.notify_one();
  }

  std::string uri_;
  std::shared_ptr<Hub> hub_;
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::deque<CanFrame> queue_;
  SoftwareFilter filter_;
  AtomicCounters counters_;
};

}  // namespace

std::unique_ptr<CanBus> open_virtual(const BusUri& uri) { return std::make_unique<VirtualEndpoint>(uri); }

}  // namespace cpgmatch::can::detail
