#include "cpgmatch/dds/security.hpp"

#include <cstdio>
#include <fstream>
#include <memory>

#include <fmt/format.h>
#include <openssl/pem.h>
#include <openssl/x509.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch::dds {

namespace fs = std::filesystem;

namespace {

SecuritySelection g_selected;

constexpr const char* kEnclaveFiles[] = {"identity_ca.cert.pem", "cert.pem", "key.pem",
                                         "permissions_ca.cert.pem", "governance.p7s", "permissions.p7s"};

// Fast DDS would refuse an expired certificate too, but only as a log line and a participant that
// cannot be created; this names the file and its date before anything starts.
void check_certificate_dates(const fs::path& file) {
  std::unique_ptr<FILE, int (*)(FILE*)> in(std::fopen(file.c_str(), "r"), &std::fclose);
  if (!in) throw InputError(fmt::format("--keystore: cannot read {}", file.string()));
  std::unique_ptr<X509, void (*)(X509*)> cert(PEM_read_X509(in.get(), nullptr, nullptr, nullptr), &X509_free);
  if (!cert) throw InputError(fmt::format("--keystore: {} is not a PEM certificate", file.string()));
  if (X509_cmp_current_time(X509_get0_notAfter(cert.get())) <= 0) {
    throw InputError(fmt::format("--keystore: the certificate {} has expired", file.string()));
  }
  if (X509_cmp_current_time(X509_get0_notBefore(cert.get())) >= 0) {
    throw InputError(fmt::format("--keystore: the certificate {} is not valid yet", file.string()));
  }
}

std::string file_uri(const fs::path& p) { return "file://" + fs::absolute(p).lexically_normal().string(); }

}  // namespace

void select_security(const SecuritySelection& selection) {
  if (selection.keystore.empty()) {
    g_selected = {};
    return;
  }
  std::error_code ec;
  if (!fs::is_directory(selection.keystore, ec)) {
    throw InputError(fmt::format("--keystore: '{}' is not a folder", selection.keystore.string()));
  }
  if (selection.enclave.empty() || selection.enclave.find('/') != std::string::npos || selection.enclave == "." ||
      selection.enclave == "..") {
    throw InputError(fmt::format("--enclave: '{}' is not an enclave name", selection.enclave));
  }
  const fs::path dir = selection.keystore / "enclaves" / selection.enclave;
  for (const char* name : kEnclaveFiles) {
    const fs::path file = dir / name;
    if (!std::ifstream(file)) throw InputError(fmt::format("--keystore: {} is missing", file.string()));
  }
  check_certificate_dates(dir / "identity_ca.cert.pem");
  check_certificate_dates(dir / "cert.pem");
  g_selected = selection;
}

std::string selected_enclave() { return g_selected.keystore.empty() ? std::string() : g_selected.enclave; }

void apply_security(eprosima::fastdds::dds::DomainParticipantQos& qos) {
  if (g_selected.keystore.empty()) return;
  const fs::path dir = g_selected.keystore / "enclaves" / g_selected.enclave;
  auto& p = qos.properties().properties();
  auto set = [&p](const std::string& name, const std::string& value) { p.emplace_back(name, value); };
  set("dds.sec.auth.plugin", "builtin.PKI-DH");
  set("dds.sec.auth.builtin.PKI-DH.identity_ca", file_uri(dir / "identity_ca.cert.pem"));
  set("dds.sec.auth.builtin.PKI-DH.identity_certificate", file_uri(dir / "cert.pem"));
  set("dds.sec.auth.builtin.PKI-DH.private_key", file_uri(dir / "key.pem"));
  set("dds.sec.access.plugin", "builtin.Access-Permissions");
  set("dds.sec.access.builtin.Access-Permissions.permissions_ca", file_uri(dir / "permissions_ca.cert.pem"));
  set("dds.sec.access.builtin.Access-Permissions.governance", file_uri(dir / "governance.p7s"));
  set("dds.sec.access.builtin.Access-Permissions.permissions", file_uri(dir / "permissions.p7s"));
  set("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
}

}  // namespace cpgmatch::dds
