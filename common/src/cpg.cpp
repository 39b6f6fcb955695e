#include "cpgmatch/cpg.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

double wrap_unit(double x) { return x - std::floor(x); }

// Wraps a phase difference into [-0.5, 0.5).
double wrap_half(double x) { return x - std::floor(x + 0.5); }

}  // namespace

Gait Gait::named(std::string_view name) {
  // Offsets are in cycles relative to the front-left leg.
  if (name == "trot") return {"trot", PerLeg<double>{0.0, 0.5, 0.5, 0.0}};
  if (name == "pace") return {"pace", PerLeg<double>{0.0, 0.5, 0.0, 0.5}};
  if (name == "bound") return {"bound", PerLeg<double>{0.0, 0.0, 0.5, 0.5}};
  if (name == "pronk") return {"pronk", PerLeg<double>{0.0, 0.0, 0.0, 0.0}};
  // Lateral-sequence walk: HL, FL, HR, FR a quarter cycle apart.
  if (name == "walk") return {"walk", PerLeg<double>{0.0, 0.5, 0.75, 0.25}};
  throw InputError(fmt::format("unknown gait '{}' (known: trot, walk, pace, bound, pronk)", name));
}

std::vector<std::string> Gait::names() { return {"trot", "walk", "pace", "bound", "pronk"}; }

PhaseOscillatorNetwork::PhaseOscillatorNetwork(Gait gait, double coupling_gain_per_s)
    : gait_(std::move(gait)), coupling_gain_(coupling_gain_per_s) {
  reset();
}

void PhaseOscillatorNetwork::reset() { reset(gait_.phase_offsets); }

void PhaseOscillatorNetwork::reset(const PerLeg<double>& phases) {
  if (phases.size() != gait_.leg_count()) throw std::invalid_argument("reset: one phase per leg of the gait");
  phases_ = PerLeg<double>(phases.size());
  cycles_ = PerLeg<long>(phases.size(), 0);
  for (std::size_t i = 0; i < phases.size(); ++i) phases_[i] = wrap_unit(phases[i]);
}

void PhaseOscillatorNetwork::step(double dt_s, double frequency_hz, const PerLeg<double>& rates) {
  const std::size_t n = phases_.size();
  PerLeg<double> velocity(n);
  for (std::size_t i = 0; i < n; ++i) {
    double coupling = 0.0;
    for (std::size_t j = 0; j < n; ++j) {
      if (j == i) continue;
      const double desired = gait_.phase_offsets[j] - gait_.phase_offsets[i];
      coupling += std::sin(kTwoPi * (phases_[j] - phases_[i] - desired));
    }
    velocity[i] = std::max(0.0, std::clamp(rates[i], 0.0, 1.0) * frequency_hz + coupling_gain_ * coupling);
  }
  for (std::size_t i = 0; i < n; ++i) {
    const double next = phases_[i] + dt_s * velocity[i];
    const double wrapped = wrap_unit(next);
    if (next >= 1.0) ++cycles_[i];
    if (next < 0.0) --cycles_[i];
    phases_[i] = wrapped;
  }
}

double PhaseOscillatorNetwork::locking_error() const {
  double worst = 0.0;
  for (std::size_t i = 0; i < phases_.size(); ++i) {
    for (std::size_t j = 0; j < phases_.size(); ++j) {
      const double actual = phases_[j] - phases_[i];
      const double desired = gait_.phase_offsets[j] - gait_.phase_offsets[i];
      worst = std::max(worst, std::abs(wrap_half(actual - desired)));
    }
  }
  return worst;
}

int pitch_harmonic(const Gait& gait, const LegLayout& legs) {
  // Every leg must have a leg of its own group half a cycle away.
  for (std::size_t a = 0; a < gait.leg_count(); ++a) {
    bool mapped = false;
    for (std::size_t b = 0; b < gait.leg_count() && !mapped; ++b) {
      if (legs.group_of.at(a) != legs.group_of.at(b)) continue;
      const double d = wrap_half(gait.phase_offsets[b] - gait.phase_offsets[a]);
      mapped = std::abs(std::abs(d) - 0.5) < 1e-9;
    }
    if (!mapped) return 1;
  }
  return 2;
}

StepTiming step_timing(const CpgParameters& params, const LegLayout& legs, int leg) {
  const double duty = legs.uses_hind_duty_factor(leg) ? params.duty_factor_hind : params.duty_factor_front;
  const double swing = 1.0 - duty;
  StepTiming t{};
  t.duty_factor = duty;
  t.knee_flex_start = duty * (1.0 - params.knee_phase_shift);
  t.retraction_start = duty + swing * (1.0 - params.overswing);
  return t;
}

double hip_profile(double phi, double duty_factor, double overswing) {
  phi = wrap_unit(phi);
  if (phi < duty_factor) {
    // Stance: sweep from front (+1) to back (-1); the foot pushes the body forward.
    return std::cos(std::numbers::pi * phi / duty_factor);
  }
  const double s = (phi - duty_factor) / (1.0 - duty_factor);  // swing progress in [0, 1)
  const double protraction_end = 1.0 - overswing;
  if (s < protraction_end || overswing <= 0.0) {
    // Protraction: back (-1) to the overswing peak (1 + overswing).
    const double u = s / protraction_end;
    return -1.0 + (2.0 + overswing) * 0.5 * (1.0 - std::cos(std::numbers::pi * u));
  }
  // Swing-leg retraction: from the peak back to +1, so the foot meets the ground moving backward.
  const double u = (s - protraction_end) / overswing;
  return 1.0 + overswing * 0.5 * (1.0 + std::cos(std::numbers::pi * u));
}

double knee_profile(double phi, double flex_start, double flex_end) {
  phi = wrap_unit(phi);
  if (phi < flex_start || phi >= flex_end || flex_end <= flex_start) return 0.0;
  const double u = (phi - flex_start) / (flex_end - flex_start);
  return 0.5 * (1.0 - std::cos(kTwoPi * u));
}

}  // namespace cpgmatch
