// The robot's sensor nodes on the CAN bus (cpgmatch's own format; Morti's sensor boards are not
// published, see docs/robot_agent.md):
//
// Foot contact (FootTile-like pressure sensor, one node per foot), CAN id = the foot's node id, 4 bytes:
//   d0..d1  normal force, uint16 big-endian, 0.01 N per unit (0..655.35 N, clamped)
//   d2      sequence counter (wraps), so a stuck sensor repeating one frame is visible
//   d3      status: bit 0 = sensor fault
// The agent thresholds the force exactly as the simulation does (common/ ContactSensor).
//
// Trunk state (rail / boom encoders and an IMU on the test rig), two frames, each on its own configurable
// frame id (the robot description's trunk_sensor: pose_frame_id, speed_frame_id, by default pose + 1):
//   pose frame, 8 bytes: x int32 (1e-5 m) | pitch int16 (1e-4 rad) | height uint16 (1e-5 m)
//   speed frame, 2 bytes: forward speed int16 (1e-3 m/s)
// all big-endian, clamped to their ranges.
#pragma once

#include <cstdint>
#include <optional>

#include "cpgmatch/can/can_frame.hpp"

namespace cpgmatch::robot {

struct FootReading {
  double force_n = 0.0;
  std::uint8_t sequence = 0;
  bool fault = false;
};

struct TrunkReading {
  double x_m = 0.0;
  double pitch_rad = 0.0;
  double height_m = 0.0;
};

inline constexpr std::uint8_t kFootFrameLength = 4;
inline constexpr std::uint8_t kTrunkPoseLength = 8;
inline constexpr std::uint8_t kTrunkSpeedLength = 2;

can::CanFrame encode_foot(std::uint32_t node_id, const FootReading& reading);
// nullopt unless a standard 4-byte data frame on node_id.
std::optional<FootReading> decode_foot(const can::CanFrame& frame, std::uint32_t node_id);

can::CanFrame encode_trunk_pose(std::uint32_t node_id, const TrunkReading& reading);
std::optional<TrunkReading> decode_trunk_pose(const can::CanFrame& frame, std::uint32_t node_id);
can::CanFrame encode_trunk_speed(std::uint32_t frame_id, double vx_mps);
std::optional<double> decode_trunk_speed(const can::CanFrame& frame, std::uint32_t frame_id);

}  // namespace cpgmatch::robot
