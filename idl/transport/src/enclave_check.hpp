// The files of a DDS-Security enclave, checked before Fast DDS sees them. Fast DDS reports a bad file as a
// log line and a participant that cannot be created (the program exits 1 without naming the file), and
// it reads the revocation list only if it is given one: a missing crl.pem switched revocation off without
// a word. Here every file the security plugins read is required, and every fault is an InputError (exit 2)
// naming the file.
#pragma once

#include <filesystem>
#include <string>

namespace cpgmatch::dds {

// What PKI-DH (authentication) and Access-Permissions read from KEYSTORE/enclaves/<name>/, all required.
inline constexpr const char* kEnclaveFiles[] = {"identity_ca.cert.pem",    "cert.pem",       "key.pem",
                                                "crl.pem",                 "permissions_ca.cert.pem",
                                                "governance.p7s",          "permissions.p7s"};

// Checks the enclave folder `dir`: every file present, a readable regular file and what it should be
// (certificates within their dates and signed by their CA, the key that of the certificate, the CRL signed
// by the identity CA, current and not revoking this certificate, governance and permissions signed by the
// permissions CA, the permissions granting this certificate's subject). Returns the certificate's common
// name. Throws InputError naming the file at the first fault.
std::string check_enclave(const std::filesystem::path& dir);

}  // namespace cpgmatch::dds
