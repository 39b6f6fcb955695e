// Flags every cpgmatch executable shares:
//   --version                          project version and git revision
//   --dds-profile local|cluster|FILE   the Fast DDS profile (deploy/fastdds/): local = Fast DDS's defaults
//                                      (multicast discovery), cluster = client of discovery servers, UDP only,
//                                      FILE = any Fast DDS XML profiles file. Without the flag Fast DDS
//                                      decides as usual ($FASTRTPS_DEFAULT_PROFILES_FILE, else defaults).
//   --discovery-server IP:PORT[;...]   the discovery servers (same as $ROS_DISCOVERY_SERVER)
//   --keystore DIR, --enclave NAME     DDS-Security: a keystore made by deploy/make-study-pki.sh (default
//                                      $CPGMATCH_KEYSTORE, else ROS 2's $ROS_SECURITY_KEYSTORE if
//                                      $ROS_SECURITY_ENABLE=true; none: no security) and the identity in it
//                                      (default $ROS_SECURITY_ENCLAVE_OVERRIDE, else per program: optimizer,
//                                      worker, operator, viewer)
// Precedence everywhere: a flag, else a CPGMATCH_* variable, else a ROS_* variable (docs/ros2.md).
#pragma once

#include <string>

#include <CLI/CLI.hpp>

namespace cpgmatch::runtime {

struct DdsFlags {
  std::string profile;            // empty: Fast DDS's own choice
  std::string discovery_servers;  // empty: $ROS_DISCOVERY_SERVER
  std::string keystore;           // empty: $CPGMATCH_KEYSTORE, else no security
  std::string enclave;            // empty: the program's default enclave
  std::string default_enclave;
};

void add_version_flag(CLI::App& app, const std::string& program);
void add_dds_flags(CLI::App& app, DdsFlags& flags, const std::string& default_enclave);

// The XML file a --dds-profile value names: local and cluster are the shipped profiles, anything else
// a path. InputError naming --dds-profile when it is neither.
std::string profiles_file_for(const std::string& profile);

// The keystore and enclave the flags and the environment select, and which variable each came from ("": a
// flag or the program's default).
struct SecurityChoice {
  std::string keystore;  // empty: no security
  std::string keystore_from;
  std::string enclave;
  std::string enclave_from;
};
SecurityChoice choose_security(const DdsFlags& flags);

// Exports the selection for this process and its children (see cpgmatch/dds/profile.hpp). A bad keystore or
// enclave is an InputError that names the variable it came from.
void apply_dds_flags(const DdsFlags& flags);

// The worker id of a simulation worker or robot agent, after apply_dds_flags. With DDS-Security the
// optimizer only takes worker ids the sender's certificate owns (its CN, or CN/suffix:
// dds::worker_id_belongs_to), so without --id the id is the certificate's CN, and an --id it does not own
// stops the program with exit 2 (InputError) instead of running a worker whose reports never count.
// Without security: `id`, or `fallback` when it is empty.
std::string resolve_worker_id(const std::string& id, const std::string& fallback);

}  // namespace cpgmatch::runtime
