#include "cpgmatch/dds/profile.hpp"

#include <cstdlib>
#include <fstream>

#include <fastdds/rtps/attributes/ServerAttributes.h>
#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch::dds {

namespace rtps = eprosima::fastrtps::rtps;

namespace {

rtps::RemoteServerList_t parse_servers(const std::string& text, const std::string& field) {
  rtps::RemoteServerList_t servers;
  // Fast DDS's own parser, so the syntax is exactly the one $ROS_DISCOVERY_SERVER has everywhere.
  if (!rtps::load_environment_server_info(text, servers) || servers.empty()) {
    throw InputError(fmt::format("{}: '{}' is not a discovery server list (IP:PORT, several separated by ';', "
                                 "the position being the server id)", field, text));
  }
  return servers;
}

}  // namespace

void select_profile(const ProfileSelection& selection) {
  if (!selection.profiles_file.empty()) {
    if (!std::ifstream(selection.profiles_file)) {
      throw InputError(fmt::format("--dds-profile: cannot read '{}'", selection.profiles_file));
    }
    setenv("FASTRTPS_DEFAULT_PROFILES_FILE", selection.profiles_file.c_str(), 1);
  }
  if (!selection.discovery_servers.empty()) {
    (void)parse_servers(selection.discovery_servers, "--discovery-server");
    setenv(rtps::DEFAULT_ROS2_MASTER_URI, selection.discovery_servers.c_str(), 1);
  }
}

void apply_discovery_servers(eprosima::fastdds::dds::DomainParticipantQos& qos) {
  auto& discovery = qos.wire_protocol().builtin.discovery_config;
  const bool client = discovery.discoveryProtocol == rtps::DiscoveryProtocol_t::CLIENT ||
                      discovery.discoveryProtocol == rtps::DiscoveryProtocol_t::SUPER_CLIENT;
  if (!client) return;
  const char* env = std::getenv(rtps::DEFAULT_ROS2_MASTER_URI);
  if (env != nullptr && *env != '\0') {
    discovery.m_DiscoveryServers = parse_servers(env, rtps::DEFAULT_ROS2_MASTER_URI);
  }
  if (discovery.m_DiscoveryServers.empty()) {
    throw InputError(
        "--dds-profile: the profile makes this process a client of discovery servers but names none; give "
        "--discovery-server IP:PORT (several separated by ';') or set ROS_DISCOVERY_SERVER");
  }
}

}  // namespace cpgmatch::dds
