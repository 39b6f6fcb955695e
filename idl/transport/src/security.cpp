#include "cpgmatch/dds/security.hpp"

#include <cstdio>
#include <cstring>
#include <memory>

#include <fmt/format.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/sha.h>
#include <openssl/x509.h>

#include "cpgmatch/errors.hpp"
#include "enclave_check.hpp"

namespace cpgmatch::dds {

namespace fs = std::filesystem;

namespace {

SecuritySelection g_selected;
std::string g_selected_cn;

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
  g_selected_cn = check_enclave(selection.keystore / "enclaves" / selection.enclave);
  g_selected = selection;
}

std::string selected_common_name() { return g_selected.keystore.empty() ? std::string() : g_selected_cn; }

std::string certificate_common_name(const fs::path& file) {
  std::unique_ptr<FILE, int (*)(FILE*)> in(std::fopen(file.c_str(), "r"), &std::fclose);
  if (!in) throw InputError(fmt::format("--keystore: cannot read {}", file.string()));
  std::unique_ptr<X509, void (*)(X509*)> cert(PEM_read_X509(in.get(), nullptr, nullptr, nullptr), &X509_free);
  if (!cert) throw InputError(fmt::format("--keystore: {} is not a PEM certificate", file.string()));
  char cn[256] = "";
  const int n = X509_NAME_get_text_by_NID(X509_get_subject_name(cert.get()), NID_commonName, cn, sizeof(cn));
  if (n <= 0) throw InputError(fmt::format("--keystore: the certificate {} has no common name (CN)", file.string()));
  return std::string(cn, static_cast<std::size_t>(n));
}

std::optional<std::string> authenticated_common_name(const std::string& token_subject,
                                                     const unsigned char (&guid_prefix)[12], std::string& why) {
  // "/CN=worker" (X509_NAME_oneline): '/'-separated FIELD=VALUE entries. Our enclave names never hold a
  // '/' (make-study-pki.sh allows A-Z a-z 0-9 . _ -); a subject that does not parse is not accepted.
  if (token_subject.empty() || token_subject[0] != '/') {
    why = fmt::format("its IdentityToken has no subject name (dds.cert.sn '{}')", token_subject);
    return std::nullopt;
  }
  std::unique_ptr<X509_NAME, void (*)(X509_NAME*)> name(X509_NAME_new(), &X509_NAME_free);
  std::string cn;
  std::size_t pos = 1;
  while (pos <= token_subject.size()) {
    const std::size_t end = std::min(token_subject.find('/', pos), token_subject.size());
    const std::string entry = token_subject.substr(pos, end - pos);
    const std::size_t eq = entry.find('=');
    if (eq == std::string::npos || eq == 0 ||
        X509_NAME_add_entry_by_txt(name.get(), entry.substr(0, eq).c_str(), MBSTRING_UTF8,
                                   reinterpret_cast<const unsigned char*>(entry.c_str() + eq + 1), -1, -1, 0) != 1) {
      why = fmt::format("its subject name '{}' does not parse", token_subject);
      return std::nullopt;
    }
    if (entry.compare(0, eq, "CN") == 0) cn = entry.substr(eq + 1);
    pos = end + 1;
  }
  if (cn.empty()) {
    why = fmt::format("its subject name '{}' has no CN", token_subject);
    return std::nullopt;
  }
  // Fast DDS (PKIDH adjust_participant_key): prefix bit 0 set, bits 1..47 = the first 47 bits of
  // SHA-256(DER subject name).
  unsigned char md[SHA256_DIGEST_LENGTH];
  unsigned int length = 0;
  if (X509_NAME_digest(name.get(), EVP_sha256(), md, &length) != 1 || length != SHA256_DIGEST_LENGTH) {
    why = "cannot hash its subject name";
    return std::nullopt;
  }
  md[5] &= 0xFE;
  const unsigned char* g = guid_prefix;
  const unsigned char bits[6] = {
      static_cast<unsigned char>((g[0] << 1) | (g[1] >> 7)), static_cast<unsigned char>((g[1] << 1) | (g[2] >> 7)),
      static_cast<unsigned char>((g[2] << 1) | (g[3] >> 7)), static_cast<unsigned char>((g[3] << 1) | (g[4] >> 7)),
      static_cast<unsigned char>((g[4] << 1) | (g[5] >> 7)), static_cast<unsigned char>(g[5] << 1)};
  if ((g[0] & 0x80) == 0 || std::memcmp(md, bits, sizeof(bits)) != 0) {
    why = fmt::format("its GUID was not derived from the subject '{}' its IdentityToken announces", token_subject);
    return std::nullopt;
  }
  return cn;
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
  // Fast DDS 2.9 PKI-DH reads a CRL from this property (PKIDH.cpp, FileProvider::load_crl) and then verifies
  // every certificate with X509_V_FLAG_CRL_CHECK: a revoked peer fails the handshake. Always given:
  // select_security() requires the file, so revocation cannot be off by accident.
  set("dds.sec.auth.builtin.PKI-DH.identity_crl", file_uri(dir / "crl.pem"));
  set("dds.sec.access.plugin", "builtin.Access-Permissions");
  set("dds.sec.access.builtin.Access-Permissions.permissions_ca", file_uri(dir / "permissions_ca.cert.pem"));
  set("dds.sec.access.builtin.Access-Permissions.governance", file_uri(dir / "governance.p7s"));
  set("dds.sec.access.builtin.Access-Permissions.permissions", file_uri(dir / "permissions.p7s"));
  set("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
}

}  // namespace cpgmatch::dds
