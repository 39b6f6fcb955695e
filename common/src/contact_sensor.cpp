#include "cpgmatch/contact_sensor.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch {

std::optional<FieldProblem> find_problem(const ContactSensorConfig& c) {
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (!(in(c.threshold_n, 0.0, 1e4) && c.threshold_n > 0.0)) return FieldProblem{"threshold_n", "must be in (0, 1e4] N"};
  if (!in(c.release_threshold_n, 0.0, c.threshold_n)) {
    return FieldProblem{"release_threshold_n", "must be in [0, threshold_n] N"};
  }
  if (!in(c.min_stable_s, 0.0, 0.1)) return FieldProblem{"min_stable_s", "must be in [0, 0.1] s"};
  if (!(in(c.poll_rate_hz, 0.0, 1e5) && c.poll_rate_hz > 0.0)) return FieldProblem{"poll_rate_hz", "must be in (0, 1e5] Hz"};
  if (!in(c.noise_std_n, 0.0, 1e3)) return FieldProblem{"noise_std_n", "must be in [0, 1e3] N"};
  if (!in(c.latency_s, 0.0, 0.1)) return FieldProblem{"latency_s", "must be in [0, 0.1] s"};
  return std::nullopt;
}

void validate(const ContactSensorConfig& c) {
  if (const auto p = find_problem(c)) throw InputError(fmt::format("contact_sensor.{}: {}", p->field, p->reason));
}

ContactSensor::ContactSensor(ContactSensorConfig config, std::uint64_t seed, std::size_t leg_count)
    : config_(config),
      rng_(seed),
      latest_(leg_count, true),
      raw_(leg_count, true),
      debounced_(leg_count, true),
      raw_since_s_(leg_count, 0.0) {
  // The latency spans latency_s x poll_rate_hz polls; twice that and a margin, so that a caller polling a
  // little faster than configured is still served in order.
  const double polls_in_flight = std::isfinite(config_.latency_s * config_.poll_rate_hz)
                                     ? std::max(0.0, config_.latency_s * config_.poll_rate_hz)
                                     : 0.0;
  pending_.resize(static_cast<std::size_t>(std::min(2.0 * polls_in_flight, 1e6)) + 4, Sample{0.0, PerLeg<bool>(leg_count, true)});
}

bool ContactSensor::debounce(int leg, double time_s, double force_n) {
  const bool raw = raw_[leg] ? force_n >= config_.release_threshold_n : force_n > config_.threshold_n;
  if (raw != raw_[leg]) {
    raw_[leg] = raw;
    raw_since_s_[leg] = time_s;
  }
  // 1e-9: poll times are multiples of the physics step and may round just below the duration.
  if (raw_[leg] != debounced_[leg] && time_s - raw_since_s_[leg] >= config_.min_stable_s - 1e-9) {
    debounced_[leg] = raw_[leg];
  }
  return debounced_[leg];
}

PerLeg<bool> ContactSensor::poll(double time_s, const PerLeg<double>& normal_forces_n) {
  const std::size_t n = latest_.size();
  if (normal_forces_n.size() != n) throw std::invalid_argument("ContactSensor::poll: one force per leg");
  Sample sample{time_s, PerLeg<bool>(n)};
  std::normal_distribution<double> noise(0.0, config_.noise_std_n);
  for (std::size_t leg = 0; leg < n; ++leg) {
    const double force = normal_forces_n[leg] + (config_.noise_std_n > 0.0 ? noise(rng_) : 0.0);
    sample.contact[leg] = debounce(leg, time_s, force);
  }
  if (count_ == pending_.size()) {
    // Polled faster than poll_rate_hz for longer than the ring holds: the oldest sample is released early
    // rather than allocating more.
    latest_ = pending_[head_].contact;
    head_ = (head_ + 1) % pending_.size();
    --count_;
  }
  pending_[(head_ + count_) % pending_.size()] = sample;
  ++count_;
  // Release every sample that is at least `latency` old; the newest released one is what we report.
  while (count_ > 0 && pending_[head_].time_s <= time_s - config_.latency_s + 1e-12) {
    latest_ = pending_[head_].contact;
    head_ = (head_ + 1) % pending_.size();
    --count_;
  }
  return latest_;
}

}  // namespace cpgmatch
