// DDS-Security for every participant of this process, switched on like ROS 2 does it: a keystore in the
// sros2 layout (deploy/make-study-pki.sh) and an enclave naming this process's identity and permissions.
// With it, Fast DDS authenticates peers (PKI-DH), enforces the signed governance and permissions (who may
// publish or subscribe to which topic) and encrypts the topics (AES-GCM).
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>

namespace cpgmatch::dds {

struct SecuritySelection {
  std::filesystem::path keystore;  // empty: no security
  std::string enclave;             // KEYSTORE/enclaves/<enclave>/
};

// Checks the enclave before any participant exists: every file the security plugins read present (crl.pem
// included), readable and what it should be (check_enclave in enclave_check.hpp; InputError naming the
// file), then uses it for every participant of this process.
void select_security(const SecuritySelection& selection);

// The selected enclave's name, empty without security (for error messages).
std::string selected_enclave();

// Adds the security plugin properties of the selected enclave, if any.
void apply_security(eprosima::fastdds::dds::DomainParticipantQos& qos);

// The common name (CN) of the selected enclave's certificate: this process's identity, and with it the
// worker ids it may use (dds::worker_id_belongs_to). Empty without security.
std::string selected_common_name();

// The CN of a PEM certificate file; InputError naming the file when it has none.
std::string certificate_common_name(const std::filesystem::path& cert_pem);

// The identity of a remote participant that DDS-Security authenticated: the CN in the subject name its
// PKI-DH IdentityToken announces (property dds.cert.sn, OpenSSL's one-line form "/CN=worker"), but only
// if that subject is the one its GUID was derived from. Fast DDS 2.9 does not compare the token's
// dds.cert.sn with the certificate of the handshake (PKIDH::validate_remote_identity leaves it unread);
// what it does check is that the first 47 bits of the participant's GUID prefix are the SHA-256 of the
// DER subject name of the certificate it authenticated. So the same derivation from the announced subject
// must give the participant's GUID prefix, or the subject is not its own. Returns the CN, or nothing and
// `why`.
std::optional<std::string> authenticated_common_name(const std::string& token_subject,
                                                     const unsigned char (&guid_prefix)[12], std::string& why);

}  // namespace cpgmatch::dds
