// How far a simulated trace is from a measured one, as a vector of residuals for least squares: at every
// tick, each channel's difference divided by its scale (what counts as one unit of misfit). The scales
// are the expected size of the misfit that is not the model values' doing (sensor noise, unmodelled
// play), so that 1 is "as good as one can hope" in every channel.
#pragma once

#include <cstddef>
#include <vector>

#include "cpgmatch/calibration/measured_trace.hpp"

namespace cpgmatch::calibration {

struct ResidualScales {
  double knee_rad = 0.01;  // knee flexion: the spring's deflection under load shows here
  double hip_rad = 0.01;   // hip angle: the gearbox and the leg's inertia show here
  double pitch_rad = 0.01; // trunk pitch
  double speed_mps = 0.05; // forward speed over the ground
  // Contact timing: a tick whose simulated contact differs from the measured one counts this much (in
  // units of the other channels' scales); 0 leaves contacts out. The contact is binary, so this residual
  // is piecewise constant in the model values: it adds to the cost, but its numeric derivative is mostly
  // zero, with a jump wherever a touchdown moves by one poll period (docs/calibration.md).
  double contact_mismatch = 1.0;
  // The foot sensors' readings, newtons; 0 leaves them out. Unlike the binary contact, the reading moves
  // smoothly with the contact's compliance and the sensor's own sensitivity and lag, which only it shows.
  double foot_force_n = 2.0;
};

// Residuals per tick of a robot with `legs` legs: the knees, the hips, pitch, speed, the contacts and the
// foot forces (18 for four legs).
inline constexpr int residuals_per_tick(std::size_t legs) { return 2 + 4 * static_cast<int>(legs); }

// Writes the residuals of ticks [first, last) of `simulated` against `measured` to `out`
// (residuals_per_tick per tick, in that order).
void tick_residuals(const MeasuredTrace& measured, const MeasuredTrace& simulated, std::size_t first, std::size_t last,
                    const ResidualScales& scales, double* out);

}  // namespace cpgmatch::calibration
