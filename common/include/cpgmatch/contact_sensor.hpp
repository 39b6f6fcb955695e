// A FootTile-like binary contact sensor: thresholded foot normal force, polled at a fixed rate,
// with optional Gaussian force noise and a fixed latency (both off by default).
#pragma once

#include <cstdint>
#include <deque>
#include <random>

#include "cpgmatch/legs.hpp"

namespace cpgmatch {

struct ContactSensorConfig {
  double threshold_n = 2.0;     // normal force above which the foot counts as in contact, newtons
  double poll_rate_hz = 250.0;  // FootTile polling rate on Morti
  double noise_std_n = 0.0;     // Gaussian noise added to the force before thresholding, newtons
  double latency_s = 0.0;       // delay between a force and the reported contact, seconds
};

class ContactSensor {
 public:
  ContactSensor(ContactSensorConfig config, std::uint64_t seed);

  // Samples the forces at time t (call at poll_rate_hz); returns the contacts as seen after the latency.
  PerLeg<bool> poll(double time_s, const PerLeg<double>& normal_forces_n);
  const PerLeg<bool>& latest() const { return latest_; }
  const ContactSensorConfig& config() const { return config_; }

 private:
  struct Sample {
    double time_s;
    PerLeg<bool> contact;
  };
  ContactSensorConfig config_;
  std::mt19937_64 rng_;
  std::deque<Sample> pending_;
  PerLeg<bool> latest_{};
};

}  // namespace cpgmatch
