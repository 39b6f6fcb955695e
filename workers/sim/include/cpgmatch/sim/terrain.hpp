// Ground shapes for the simulation: flat, a single step up or down, or seeded random roughness.
#pragma once

#include <cstdint>
#include <string>

namespace cpgmatch::sim {

struct TerrainSpec {
  enum class Kind { kFlat, kStep, kRough };
  Kind kind = Kind::kFlat;
  double step_height_m = 0.0;    // + up, - down
  double step_distance_m = 1.0;  // world x of the step edge (the trunk starts at x = 0)
  double rough_amplitude_m = 0.0;
  double rough_tile_length_m = 0.08;
  double rough_start_m = 0.4;    // flat ground before this, so the robot starts standing level
  double treadmill_speed_mps = 0.0;

  // Parses "flat", "step:HEIGHT@DISTANCE" or "rough:AMPLITUDE" (metres). Throws InputError.
  static TerrainSpec parse(const std::string& text);
  std::string describe() const;
};

}  // namespace cpgmatch::sim
