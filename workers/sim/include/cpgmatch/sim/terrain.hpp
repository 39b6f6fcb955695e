// Ground shapes for the simulation: flat, a single step up or down, or seeded random roughness.
#pragma once

#include <cstdint>
#include <string>

namespace cpgmatch::sim {

struct TerrainSpec {
  enum class Kind { kFlat, kStep, kRough, kShift };
  Kind kind = Kind::kFlat;
  double step_height_m = 0.0;    // + up, - down
  double step_distance_m = 1.0;  // world x of the step edge (the trunk starts at x = 0)
  double rough_amplitude_m = 0.0;
  double rough_tile_length_m = 0.08;
  double rough_start_m = 0.4;    // flat ground before this, so the robot starts standing level
  double treadmill_speed_mps = 0.0;
  double treadmill_ramp_s = 2.0;  // the belt accelerates from rest over this time, like a real treadmill
  // kShift: flat ground that moves vertically by shift_height_m at time shift_time_s (a controlled
  // perturbation: everything before the shift is identical to flat ground).
  double shift_height_m = 0.0;
  double shift_time_s = 0.0;

  // Parses "flat", "step:HEIGHT@DISTANCE", "rough:AMPLITUDE" (metres) or "shift:HEIGHT@TIME" (metres,
  // seconds). Throws InputError.
  static TerrainSpec parse(const std::string& text);
  // Every terrain parse() accepts, with its units and limits: the one text help and errors show.
  static const char* syntax();
  std::string describe() const;
};

}  // namespace cpgmatch::sim
