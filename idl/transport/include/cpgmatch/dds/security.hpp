// DDS-Security for every participant of this process, switched on like ROS 2 does it: a keystore in the
// sros2 layout (deploy/make-study-pki.sh) and an enclave naming this process's identity and permissions.
// With it, Fast DDS authenticates peers (PKI-DH), enforces the signed governance and permissions (who may
// publish or subscribe to which topic) and encrypts the topics (AES-GCM).
#pragma once

#include <filesystem>
#include <string>

#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>

namespace cpgmatch::dds {

struct SecuritySelection {
  std::filesystem::path keystore;  // empty: no security
  std::string enclave;             // KEYSTORE/enclaves/<enclave>/
};

// Checks the enclave before any participant exists: every file present and readable, certificates not
// expired (InputError naming the file), then uses it for every participant of this process.
void select_security(const SecuritySelection& selection);

// The selected enclave's name, empty without security (for error messages).
std::string selected_enclave();

// Adds the security plugin properties of the selected enclave, if any.
void apply_security(eprosima::fastdds::dds::DomainParticipantQos& qos);

}  // namespace cpgmatch::dds
