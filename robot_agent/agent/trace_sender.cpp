#include "trace_sender.hpp"

#include <spdlog/spdlog.h>

#include "cpgmatch/dds/convert_trace.hpp"

namespace cpgmatch::robot {

TraceSender::TraceSender(dds::Participant& participant) : writer_(participant), thread_([this] { loop(); }) {}

TraceSender::~TraceSender() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void TraceSender::send(domain::RolloutTrace trace) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (queue_.size() >= kMaxQueued) {
      const domain::RolloutTrace& old = queue_.front();
      spdlog::warn("study {} trial {}: its trace was not sent ({} traces waiting already)", old.id.study_id,
                   old.id.trial_id, queue_.size());
      queue_.pop_front();
    }
    queue_.push_back(std::move(trace));
  }
  changed_.notify_all();
}

void TraceSender::drain(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!changed_.wait_for(lock, timeout, [this] { return queue_.empty() && !busy_; })) {
    spdlog::warn("{} rollout trace(s) not sent before leaving", queue_.size() + (busy_ ? 1 : 0));
  }
}

void TraceSender::loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    changed_.wait(lock, [this] { return stop_ || !queue_.empty(); });
    if (stop_) return;
    const domain::RolloutTrace trace = std::move(queue_.front());
    queue_.pop_front();
    busy_ = true;
    lock.unlock();
    send_now(trace);
    lock.lock();
    busy_ = false;
    changed_.notify_all();
  }
}

void TraceSender::send_now(const domain::RolloutTrace& trace) {
  const auto start = std::chrono::steady_clock::now();
  const std::vector<domain::RolloutTraceChunk> chunks = domain::split_trace(trace);
  msg::RolloutTraceChunk key;
  std::size_t failed = 0;
  for (const auto& chunk : chunks) {
    key = dds::to_wire(chunk);
    if (!writer_.write(key)) ++failed;
  }
  const bool acknowledged = writer_.wait_for_acknowledgments(kAcknowledgeWait);
  writer_.unregister(key);  // the trial's instance: frees the chunks kept for repairs
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (failed > 0 || !acknowledged) {
    spdlog::warn("study {} trial {}: trace of {} ticks: {} of {} chunks failed to write, {}", trace.id.study_id,
                 trace.id.trial_id, trace.trace.ticks.size(), failed, chunks.size(),
                 acknowledged ? "the rest acknowledged" : "not acknowledged in time (is an optimizer listening?)");
  } else {
    spdlog::info("study {} trial {}: trace of {} ticks sent in {} chunks, acknowledged in {:.2f} s{}", trace.id.study_id,
                 trace.id.trial_id, trace.trace.ticks.size(), chunks.size(), seconds,
                 trace.ticks_dropped > 0 ? fmt::format(" ({} later ticks not kept)", trace.ticks_dropped) : "");
  }
}

}  // namespace cpgmatch::robot
