// The motor protocols by name: "mit", "odrive", "moteus". Construction allocates; the objects it makes do
// not (their command and decode paths run in the real-time loop).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string_view>

#include "cpgmatch/robot/mit_protocol.hpp"
#include "cpgmatch/robot/moteus_protocol.hpp"
#include "cpgmatch/robot/odrive_protocol.hpp"

namespace cpgmatch::robot {

inline constexpr std::array<std::string_view, 3> kMotorProtocols{"mit", "odrive", "moteus"};

bool is_motor_protocol(std::string_view name);

struct ProtocolSettings {
  std::uint32_t host_id = 0;  // mit: the reply id; moteus: the agent's source id
  MitRanges mit;
  OdriveSettings odrive;
  MoteusSettings moteus;  // its host_id is taken from host_id above
};

// Throws std::invalid_argument for an unknown name or a node id outside the protocol's range.
std::unique_ptr<MotorProtocol> make_motor_protocol(std::string_view name, std::uint32_t node_id, const ProtocolSettings& settings);

}  // namespace cpgmatch::robot
