#include "cpgmatch/calibration/replay_cache.hpp"

#include <algorithm>

namespace cpgmatch::calibration {

ReplayCache::ReplayCache(sim::PlanarLegModel start, std::vector<const ModelValue*> values, std::vector<double> scales,
                         const std::vector<CalibrationTrace>& traces, std::size_t capacity)
    : start_(start), values_(std::move(values)), scales_(std::move(scales)), traces_(traces), capacity_(capacity) {}

sim::PlanarLegModel ReplayCache::model_at(const double* x) const {
  sim::PlanarLegModel model = start_;
  for (std::size_t i = 0; i < values_.size(); ++i) {
    values_[i]->set(model, std::clamp(x[i] * scales_[i], values_[i]->lower, values_[i]->upper));
  }
  return model;
}

const std::vector<MeasuredTrace>* ReplayCache::replays_at(const double* x) {
  const std::size_t n = values_.size();
  for (auto it = entries_.begin(); it != entries_.end(); ++it) {
    if (std::equal(it->x.begin(), it->x.end(), x)) {
      entries_.splice(entries_.begin(), entries_, it);
      return entries_.front().replays ? &*entries_.front().replays : nullptr;
    }
  }
  Entry entry{std::vector<double>(x, x + n), std::vector<MeasuredTrace>{}};
  const sim::PlanarLegModel model = model_at(x);
  for (const CalibrationTrace& trace : traces_) {
    ++replays_run_;
    auto replayed = replay(model, trace.commands, trace.setup);
    if (!replayed) {
      entry.replays.reset();
      break;
    }
    entry.replays->push_back(std::move(*replayed));
  }
  entries_.push_front(std::move(entry));
  if (entries_.size() > capacity_) entries_.pop_back();
  return entries_.front().replays ? &*entries_.front().replays : nullptr;
}

}  // namespace cpgmatch::calibration
