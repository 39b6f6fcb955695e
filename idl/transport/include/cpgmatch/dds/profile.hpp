// Which Fast DDS configuration this process's participants start from. Chosen once at startup, before
// the first participant, and passed on to child processes through the environment variables Fast DDS
// itself reads, so a user who knows Fast DDS finds no surprise:
//   profiles file     -> $FASTRTPS_DEFAULT_PROFILES_FILE (its default participant profile applies)
//   discovery servers -> $ROS_DISCOVERY_SERVER ("IP:PORT;IP:PORT", the position is the server id)
// Fast DDS turns a SIMPLE-discovery participant into a client of $ROS_DISCOVERY_SERVER on its own; for
// a profile that is already a discovery-server client (deploy/fastdds/cluster.xml) the servers are
// filled in here, so one profile file serves every cluster.
#pragma once

#include <string>

#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>

namespace cpgmatch::dds {

struct ProfileSelection {
  std::string profiles_file;      // empty: keep Fast DDS's own choice
  std::string discovery_servers;  // empty: keep $ROS_DISCOVERY_SERVER
};

// Checks both (InputError naming --dds-profile or --discovery-server) and exports them.
void select_profile(const ProfileSelection& selection);

// For a discovery-server client profile: the servers from $ROS_DISCOVERY_SERVER. InputError when the
// profile is a client and no server is named anywhere.
void apply_discovery_servers(eprosima::fastdds::dds::DomainParticipantQos& qos);

}  // namespace cpgmatch::dds
