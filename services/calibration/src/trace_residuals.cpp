#include "cpgmatch/calibration/trace_residuals.hpp"

namespace cpgmatch::calibration {

void tick_residuals(const MeasuredTrace& measured, const MeasuredTrace& simulated, std::size_t first, std::size_t last,
                    const ResidualScales& scales, double* out) {
  for (std::size_t i = first; i < last; ++i) {
    const MeasuredTick& m = measured.ticks[i];
    const MeasuredTick& s = simulated.ticks[i];
    const std::size_t legs = m.legs.size();
    for (std::size_t leg = 0; leg < legs; ++leg) *out++ = (s.legs[leg].knee_rad - m.legs[leg].knee_rad) / scales.knee_rad;
    for (std::size_t leg = 0; leg < legs; ++leg) *out++ = (s.legs[leg].hip_rad - m.legs[leg].hip_rad) / scales.hip_rad;
    *out++ = (s.pitch_rad - m.pitch_rad) / scales.pitch_rad;
    *out++ = (s.vx_mps - m.vx_mps) / scales.speed_mps;
    for (std::size_t leg = 0; leg < legs; ++leg) {
      *out++ = scales.contact_mismatch * (static_cast<double>(s.legs[leg].contact) - static_cast<double>(m.legs[leg].contact));
    }
    for (std::size_t leg = 0; leg < legs; ++leg) {
      *out++ = scales.foot_force_n > 0.0 ? (s.legs[leg].foot_force_n - m.legs[leg].foot_force_n) / scales.foot_force_n : 0.0;
    }
  }
}

}  // namespace cpgmatch::calibration
