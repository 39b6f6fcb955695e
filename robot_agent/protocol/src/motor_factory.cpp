#include "cpgmatch/robot/motor_factory.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace cpgmatch::robot {

bool is_motor_protocol(std::string_view name) {
  return std::find(kMotorProtocols.begin(), kMotorProtocols.end(), name) != kMotorProtocols.end();
}

std::unique_ptr<MotorProtocol> make_motor_protocol(std::string_view name, std::uint32_t node_id, const ProtocolSettings& s) {
  if (name == "mit") return std::make_unique<MitMotor>(node_id, s.host_id, s.mit);
  if (name == "odrive") return std::make_unique<OdriveMotor>(node_id, s.odrive);
  if (name == "moteus") {
    MoteusSettings m = s.moteus;
    m.host_id = s.host_id;
    return std::make_unique<MoteusMotor>(node_id, m);
  }
  throw std::invalid_argument("unknown motor protocol '" + std::string(name) + "' (known: mit, odrive, moteus)");
}

}  // namespace cpgmatch::robot
