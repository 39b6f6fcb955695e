// A FootTile-like binary contact sensor: the foot's normal force, polled at a fixed rate, thresholded with
// hysteresis and debounced, with optional Gaussian force noise and a fixed latency (both off by default).
//
// Why hysteresis and a minimum duration: a FootTile is an analogue pressure sensor, and a single threshold
// on it flickers whenever the force hovers near the threshold (touchdown transients, a toe scuffing the
// ground at toe-off, sensor noise). Every flicker would look to the feedback mechanisms like a real
// touchdown or toe-off. Contact is therefore *made* only above `threshold_n`, *released* only below
// `release_threshold_n`, and a change is reported only once the raw state has held for `min_stable_s`.
// The reported contact lags a clean edge by min_stable_s (8 ms = 2 polls by default), a delay of the same
// order as the sensor's own 3 ms sample period.
#pragma once

#include <cstdint>
#include <vector>
#include <optional>
#include <random>
#include <string>

#include "cpgmatch/legs.hpp"

namespace cpgmatch {

struct ContactSensorConfig {
  double threshold_n = 2.0;          // force above which contact is made, newtons
  double release_threshold_n = 1.0;  // force below which contact is released, newtons (<= threshold_n)
  double min_stable_s = 0.008;       // a raw change must hold this long before it is reported, seconds
  double poll_rate_hz = 250.0;       // FootTile polling rate on Morti
  double noise_std_n = 0.0;          // Gaussian noise added to the force before thresholding, newtons
  double latency_s = 0.0;            // delay between a force and the reported contact, seconds
};

struct FieldProblem {
  std::string field;   // the config key, e.g. "release_threshold_n"
  std::string reason;  // what is wrong with it
};

// The first field out of its range, if any (shared by the YAML loader, which adds file:line, and validate()).
std::optional<FieldProblem> find_problem(const ContactSensorConfig& config);
// Throws InputError "contact_sensor.<field>: <reason>" for the first bad field.
void validate(const ContactSensorConfig& config);

class ContactSensor {
 public:
  // One sensor per leg; the feet start in contact.
  ContactSensor(ContactSensorConfig config, std::uint64_t seed, std::size_t leg_count);

  // Samples the forces at time t (call at poll_rate_hz); returns the contacts as seen after the latency.
  // The feet start in contact (a rollout starts standing).
  PerLeg<bool> poll(double time_s, const PerLeg<double>& normal_forces_n);
  const PerLeg<bool>& latest() const { return latest_; }
  const ContactSensorConfig& config() const { return config_; }

 private:
  struct Sample {
    double time_s;
    PerLeg<bool> contact;
  };
  // Hysteresis and debouncing of one leg's raw force; returns the debounced state.
  bool debounce(int leg, double time_s, double force_n);

  ContactSensorConfig config_;
  std::mt19937_64 rng_;
  // Samples not yet released (the latency), oldest at head_: a ring allocated once at construction, so
  // polling never touches the heap inside the robot's real-time loop.
  std::vector<Sample> pending_;
  std::size_t head_ = 0;
  std::size_t count_ = 0;
  PerLeg<bool> latest_;
  PerLeg<bool> raw_;                  // the hysteresis output, before the minimum duration
  PerLeg<bool> debounced_;
  PerLeg<double> raw_since_s_;        // when raw_ last changed
};

}  // namespace cpgmatch
