#include "enclave_check.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <set>
#include <vector>

#include <fmt/format.h>
#include <openssl/err.h>
#include <openssl/objects.h>
#include <openssl/pem.h>
#include <openssl/pkcs7.h>
#include <openssl/x509.h>
#include <openssl/x509_vfy.h>

#include "cpgmatch/dds/security.hpp"
#include "cpgmatch/errors.hpp"

namespace cpgmatch::dds {

namespace fs = std::filesystem;

namespace {

using X509Ptr = std::unique_ptr<X509, decltype(&X509_free)>;
using StorePtr = std::unique_ptr<X509_STORE, decltype(&X509_STORE_free)>;
using BioPtr = std::unique_ptr<BIO, decltype(&BIO_free)>;

[[noreturn]] void fail(const fs::path& file, const std::string& what) {
  ERR_clear_error();  // OpenSSL's queue is shared with Fast DDS: leave nothing of ours in it
  throw InputError(fmt::format("--keystore: {} {}", file.string(), what));
}

// OpenSSL's reason for the last failure, for a message.
std::string openssl_reason() {
  const unsigned long code = ERR_peek_last_error();
  const char* reason = code != 0 ? ERR_reason_error_string(code) : nullptr;
  return reason != nullptr ? reason : "no reason given";
}

// The whole file. Missing (then `missing_hint` follows the message), not a regular file, unreadable or
// empty: InputError naming it.
std::string read_file(const fs::path& file, const std::string& missing_hint) {
  std::error_code ec;
  const fs::file_status status = fs::status(file, ec);
  if (status.type() == fs::file_type::not_found) fail(file, "is missing" + missing_hint);
  if (ec) fail(file, fmt::format("cannot be read: {}", ec.message()));
  if (status.type() != fs::file_type::regular) fail(file, "is not a regular file");
  std::unique_ptr<FILE, int (*)(FILE*)> in(std::fopen(file.c_str(), "rb"), &std::fclose);
  if (!in) fail(file, fmt::format("cannot be read: {}", std::strerror(errno)));
  std::string data;
  char buffer[4096];
  for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, in.get())) > 0;) data.append(buffer, n);
  if (std::ferror(in.get())) fail(file, "cannot be read: read error");
  if (data.empty()) fail(file, "is empty");
  return data;
}

BioPtr memory_bio(const std::string& data) {
  return BioPtr(BIO_new_mem_buf(data.data(), static_cast<int>(data.size())), &BIO_free);
}

X509Ptr certificate(const fs::path& file, const std::string& pem) {
  X509Ptr cert(PEM_read_bio_X509(memory_bio(pem).get(), nullptr, nullptr, nullptr), &X509_free);
  if (!cert) fail(file, "is not a PEM certificate");
  return cert;
}

// Fast DDS would refuse an expired certificate too, but only as a log line and a participant that cannot
// be created; this names the file before anything starts.
void check_dates(const fs::path& file, X509* cert) {
  if (X509_cmp_current_time(X509_get0_notAfter(cert)) <= 0) {
    throw InputError(fmt::format("--keystore: the certificate {} has expired", file.string()));
  }
  if (X509_cmp_current_time(X509_get0_notBefore(cert)) >= 0) {
    throw InputError(fmt::format("--keystore: the certificate {} is not valid yet", file.string()));
  }
}

StorePtr store_of(X509* ca) {
  StorePtr store(X509_STORE_new(), &X509_STORE_free);
  X509_STORE_add_cert(store.get(), ca);
  return store;
}

// PKI-DH verifies its own certificate against the identity CA; one from another keystore (a copied
// cert.pem) fails there.
void check_signed_by(const fs::path& cert_file, X509* cert, const fs::path& ca_file, X509* ca) {
  const StorePtr store = store_of(ca);
  std::unique_ptr<X509_STORE_CTX, decltype(&X509_STORE_CTX_free)> ctx(X509_STORE_CTX_new(), &X509_STORE_CTX_free);
  if (!ctx || X509_STORE_CTX_init(ctx.get(), store.get(), cert, nullptr) != 1) fail(cert_file, "cannot be verified");
  if (X509_verify_cert(ctx.get()) != 1) {
    fail(cert_file, fmt::format("is not signed by {} ({}): a certificate of another keystore?", ca_file.string(),
                                X509_verify_cert_error_string(X509_STORE_CTX_get_error(ctx.get()))));
  }
}

void check_private_key(const fs::path& key_file, const std::string& pem, const fs::path& cert_file, X509* cert) {
  std::unique_ptr<EVP_PKEY, decltype(&EVP_PKEY_free)> key(
      PEM_read_bio_PrivateKey(memory_bio(pem).get(), nullptr, nullptr, nullptr), &EVP_PKEY_free);
  if (!key) fail(key_file, "is not a PEM private key (or it is encrypted)");
  if (X509_check_private_key(cert, key.get()) != 1) fail(key_file, fmt::format("is not the key of {}", cert_file.string()));
}

// The enclave's certificate revocation list. Fast DDS checks every peer's certificate against it (PKI-DH
// identity_crl); a CRL of another CA or an expired one would make it refuse every peer, and one that
// revokes our own certificate would make the participant fail without a word.
void check_crl(const fs::path& crl_file, const std::string& pem, const fs::path& ca_file, X509* ca,
               const fs::path& cert_file, X509* cert) {
  std::unique_ptr<X509_CRL, decltype(&X509_CRL_free)> crl(
      PEM_read_bio_X509_CRL(memory_bio(pem).get(), nullptr, nullptr, nullptr), &X509_CRL_free);
  if (!crl) fail(crl_file, "is not a PEM certificate revocation list");
  if (X509_CRL_verify(crl.get(), X509_get0_pubkey(ca)) != 1) {
    fail(crl_file, fmt::format("is not signed by {}: the revocation list of another keystore?", ca_file.string()));
  }
  if (const ASN1_TIME* next = X509_CRL_get0_nextUpdate(crl.get()); next != nullptr && X509_cmp_current_time(next) <= 0) {
    throw InputError(fmt::format("--keystore: the revocation list {} has expired (make a fresh one: make-study-pki.sh "
                                 "KEYSTORE revoke)",
                                 crl_file.string()));
  }
  X509_REVOKED* revoked = nullptr;
  if (X509_CRL_get0_by_cert(crl.get(), &revoked, cert) == 1) {
    throw InputError(fmt::format("--keystore: the certificate {} has been revoked ({})", cert_file.string(),
                                 crl_file.string()));
  }
}

// The content of an S/MIME signed document (governance.p7s, permissions.p7s), verified as Access-Permissions
// verifies it: PKCS7_verify against the permissions CA, text mode.
std::string signed_content(const fs::path& file, const std::string& smime, const fs::path& ca_file, X509* ca) {
  BIO* detached = nullptr;
  std::unique_ptr<PKCS7, decltype(&PKCS7_free)> p7(SMIME_read_PKCS7(memory_bio(smime).get(), &detached), &PKCS7_free);
  const BioPtr content(detached, &BIO_free);
  if (!p7) fail(file, "is not an S/MIME signed document (corrupt?)");
  const StorePtr store = store_of(ca);
  const BioPtr out(BIO_new(BIO_s_mem()), &BIO_free);
  if (PKCS7_verify(p7.get(), nullptr, store.get(), content.get(), out.get(), PKCS7_TEXT) != 1) {
    fail(file, fmt::format("is not signed by {} ({}): corrupt, or from another keystore?", ca_file.string(),
                           openssl_reason()));
  }
  char* data = nullptr;
  const long size = BIO_get_mem_data(out.get(), &data);
  return std::string(data, static_cast<std::size_t>(size));
}

// A distinguished name as the set of its parts "TYPE=value", types by OpenSSL's short name, order aside
// (Fast DDS compares a grant's subject with the certificate's without regard to order). A permissions file
// writes it as text, "CN=worker" or "C=DE, O=lab, CN=node12"; escaped commas ("O=a\, b") are understood.
using NameParts = std::set<std::string>;

std::string trimmed(const std::string& s) {
  const std::size_t first = s.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
}

void add_part(NameParts& parts, const std::string& part) {
  const std::size_t eq = part.find('=');
  if (eq == std::string::npos) return;
  const std::string type = trimmed(part.substr(0, eq));
  std::string value = trimmed(part.substr(eq + 1));
  if (value.size() >= 2 && value.front() == '"' && value.back() == '"') value = value.substr(1, value.size() - 2);
  const int nid = OBJ_txt2nid(type.c_str());
  parts.insert((nid != NID_undef ? OBJ_nid2sn(nid) : type) + "=" + value);
}

NameParts name_parts(const std::string& text) {
  NameParts parts;
  std::string part;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '\\' && i + 1 < text.size()) {
      part += text[++i];
    } else if (text[i] == ',') {
      add_part(parts, part);
      part.clear();
    } else {
      part += text[i];
    }
  }
  add_part(parts, part);
  return parts;
}

NameParts name_parts(const X509_NAME* name) {
  NameParts parts;
  for (int i = 0; i < X509_NAME_entry_count(name); ++i) {
    const X509_NAME_ENTRY* entry = X509_NAME_get_entry(name, i);
    unsigned char* utf8 = nullptr;
    const int n = ASN1_STRING_to_UTF8(&utf8, X509_NAME_ENTRY_get_data(entry));
    if (n < 0) continue;
    const int nid = OBJ_obj2nid(X509_NAME_ENTRY_get_object(entry));
    parts.insert(std::string(OBJ_nid2sn(nid)) + "=" + std::string(reinterpret_cast<char*>(utf8), static_cast<std::size_t>(n)));
    OPENSSL_free(utf8);
  }
  return parts;
}

// The <subject_name> of every grant in a permissions document.
std::vector<std::string> grant_subjects(const std::string& xml) {
  static const std::string open = "<subject_name>", close = "</subject_name>";
  std::vector<std::string> subjects;
  for (std::size_t at = xml.find(open); at != std::string::npos; at = xml.find(open, at + 1)) {
    const std::size_t end = xml.find(close, at);
    if (end == std::string::npos) break;
    subjects.push_back(trimmed(xml.substr(at + open.size(), end - at - open.size())));
  }
  return subjects;
}

// Access-Permissions takes the grant whose subject is its certificate's; with none (the permissions.p7s of
// another enclave) the participant cannot be created.
void check_grant(const fs::path& permissions_file, const std::string& xml, const fs::path& cert_file, X509* cert) {
  const NameParts own = name_parts(X509_get_subject_name(cert));
  const std::vector<std::string> subjects = grant_subjects(xml);
  for (const std::string& subject : subjects) {
    if (name_parts(subject) == own) return;
  }
  std::string listed;
  for (const std::string& subject : subjects) listed += (listed.empty() ? "" : ", ") + ("'" + subject + "'");
  std::unique_ptr<char, void (*)(void*)> cert_subject(X509_NAME_oneline(X509_get_subject_name(cert), nullptr, 0),
                                                      [](void* p) { OPENSSL_free(p); });
  fail(permissions_file, fmt::format("grants {} but not the subject of {} ({}): the permissions of another enclave?",
                                     listed.empty() ? "no subject" : listed, cert_file.string(),
                                     cert_subject ? cert_subject.get() : "?"));
}

}  // namespace

std::string check_enclave(const fs::path& dir) {
  std::map<std::string, std::string> data;  // file name -> contents: every file read (or named) first
  for (const char* name : kEnclaveFiles) {
    // Keystores made before revocation existed have no crl.pem; without one, revoked identities get in.
    const bool crl = std::strcmp(name, "crl.pem") == 0;
    data[name] = read_file(dir / name, crl ? " (every enclave needs its CA's revocation list; make-study-pki.sh "
                                             "KEYSTORE revoke writes a fresh one into every enclave)"
                                           : "");
  }
  const auto path = [&dir](const char* name) { return dir / name; };

  const X509Ptr identity_ca = certificate(path("identity_ca.cert.pem"), data["identity_ca.cert.pem"]);
  check_dates(path("identity_ca.cert.pem"), identity_ca.get());
  const X509Ptr cert = certificate(path("cert.pem"), data["cert.pem"]);
  check_dates(path("cert.pem"), cert.get());
  check_signed_by(path("cert.pem"), cert.get(), path("identity_ca.cert.pem"), identity_ca.get());
  check_private_key(path("key.pem"), data["key.pem"], path("cert.pem"), cert.get());
  check_crl(path("crl.pem"), data["crl.pem"], path("identity_ca.cert.pem"), identity_ca.get(), path("cert.pem"),
            cert.get());

  const X509Ptr permissions_ca = certificate(path("permissions_ca.cert.pem"), data["permissions_ca.cert.pem"]);
  check_dates(path("permissions_ca.cert.pem"), permissions_ca.get());
  (void)signed_content(path("governance.p7s"), data["governance.p7s"], path("permissions_ca.cert.pem"),
                       permissions_ca.get());
  const std::string permissions = signed_content(path("permissions.p7s"), data["permissions.p7s"],
                                                 path("permissions_ca.cert.pem"), permissions_ca.get());
  check_grant(path("permissions.p7s"), permissions, path("cert.pem"), cert.get());
  ERR_clear_error();
  return certificate_common_name(path("cert.pem"));
}

}  // namespace cpgmatch::dds
