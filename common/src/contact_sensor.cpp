#include "cpgmatch/contact_sensor.hpp"

namespace cpgmatch {

ContactSensor::ContactSensor(ContactSensorConfig config, std::uint64_t seed)
    : config_(config), rng_(seed) {}

PerLeg<bool> ContactSensor::poll(double time_s, const PerLeg<double>& normal_forces_n) {
  Sample sample{time_s, {}};
  std::normal_distribution<double> noise(0.0, config_.noise_std_n);
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const double force = normal_forces_n[leg] + (config_.noise_std_n > 0.0 ? noise(rng_) : 0.0);
    sample.contact[leg] = force > config_.threshold_n;
  }
  pending_.push_back(sample);
  // Release every sample that is at least `latency` old; the newest released one is what we report.
  while (!pending_.empty() && pending_.front().time_s <= time_s - config_.latency_s + 1e-12) {
    latest_ = pending_.front().contact;
    pending_.pop_front();
  }
  return latest_;
}

}  // namespace cpgmatch
