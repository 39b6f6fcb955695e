// The central pattern generator: one phase oscillator per leg, coupled, and the joint trajectories they drive.
//
// This is the phase-space form of the modified Hopf oscillator used by Ruppert & Badri-Sproewitz (2022):
// one phase per leg, phi_i in [0, 1) cycles, integrated as
//
//     dphi_i/dt = max(0, rate_i * f + K * sum_j sin(2 pi (phi_j - phi_i - d_ij)))
//
// where f is the step frequency (Hz), K the coupling gain (1/s), d_ij = offset_j - offset_i the desired
// phase difference from the gait's phase-offset vector, and rate_i in [0, 1] the feedback's deceleration
// of the node's own frequency (1 = free running; the coupling is not scaled, see step()). A phase never
// runs backwards. A gait is therefore data: a vector of phase offsets, one per leg (2, 4, 6, ... legs).
//
// Convention inside one leg's cycle: phi = 0 is the nominal touchdown, [0, D) is stance, [D, 1) swing,
// with D the duty factor of that leg. The oscillator runs uniformly; the duty factor only shapes the
// joint trajectories (see JointTrajectory), so phase locking does not depend on front/hind duty factors.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "cpgmatch/legs.hpp"
#include "cpgmatch/params.hpp"

namespace cpgmatch {

struct Gait {
  std::string name;
  PerLeg<double> phase_offsets;  // cycles, one per leg in the robot's leg order

  // The quadruped gaits for LegLayout::quadruped()'s FL FR HL HR: trot, walk, pace, bound, pronk. Throws
  // InputError for an unknown name. A robot description brings its own gaits (RobotDescription::gaits).
  static Gait named(std::string_view name);
  static std::vector<std::string> names();
  std::size_t leg_count() const { return phase_offsets.size(); }
};

class PhaseOscillatorNetwork {
 public:
  PhaseOscillatorNetwork(Gait gait, double coupling_gain_per_s);

  // Starts every oscillator at its gait offset (already phase locked).
  void reset();
  // Starts from arbitrary phases, one per leg (used by tests of the locking dynamics).
  void reset(const PerLeg<double>& phases);

  // Explicit Euler step of dt seconds; rates are the per-leg phase-deceleration factors in [0, 1].
  // A rate scales the node's own frequency only: dphi_i/dt = rate_i f + K sum_j sin(2 pi (phi_j - phi_i - psi_ij)).
  // Feedback modulates an oscillator and its coupling inputs stay, so a held leg is still pulled along by
  // the others and slows them in turn. For a trot its lag settles at asin((1 - rate) f / (4 K)) / 2 pi
  // cycles (0.074 at the shipped rate 0.1, 1/12 at rate 0, for f 1 Hz and K 0.5/s; unbounded only if
  // (1 - rate) f > 4 K). Scaling the coupling as well (before 2026-12-02) let a waiting leg drift out of
  // the gait without bound while its partners walked on (docs/model.md, "Feedback on random gaits").
  // The velocity is floored at 0: a held leg that is ahead of its partners waits for them instead of
  // running backwards (a backward step across 0 would look like a new swing to the leg's feedback).
  void step(double dt_s, double frequency_hz, const PerLeg<double>& rates);

  const PerLeg<double>& phases() const { return phases_; }
  // Cycles completed by each leg since reset (integer part of the unwrapped phase).
  const PerLeg<long>& cycles() const { return cycles_; }
  const Gait& gait() const { return gait_; }

  // Largest deviation of the wrapped phase differences from the gait's, in cycles (0 = locked).
  double locking_error() const;

 private:
  Gait gait_;
  double coupling_gain_;
  PerLeg<double> phases_{};
  PerLeg<long> cycles_{};
};

// How many times per CPG cycle body pitch repeats in a clean gait of this pattern: 2 when shifting the
// pattern by half a cycle maps every leg onto a leg of its own group (trot, pace, walk: each front and each
// hind pair steps twice per cycle, so front-hind loading and hence pitch repeat twice; a hexapod's tripod),
// otherwise 1 (bound, pronk). Body pitch is set by fore-aft loading, not by left versus right.
int pitch_harmonic(const Gait& gait, const LegLayout& legs);

// Key phases (cycles) of one leg's step, derived from the parameters.
struct StepTiming {
  double duty_factor;      // stance ends (nominal toe-off, hip starts to protract)
  double knee_flex_start;  // knee flexion begins (leads toe-off by knee_phase_shift of the stance)
  double retraction_start; // swing-leg retraction begins; knee is extended again here
};

// The leg's group decides its duty factor (LegLayout::uses_hind_duty_factor).
StepTiming step_timing(const CpgParameters& params, const LegLayout& legs, int leg);

// Hip shape in units of the hip amplitude as a function of phase: +1 at touchdown, -1 at toe-off,
// 1 + overswing at the start of retraction. Continuous in phi.
double hip_profile(double phi, double duty_factor, double overswing);

// Knee flexion in units of the knee amplitude: a raised cosine between flex_start and flex_end
// (wrapping through 1 -> 0 is not needed because flex_start < flex_end < 1).
double knee_profile(double phi, double flex_start, double flex_end);

}  // namespace cpgmatch
