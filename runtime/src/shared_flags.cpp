#include "cpgmatch/runtime/shared_flags.hpp"

#include <cstdlib>
#include <filesystem>
#include <system_error>

#include <fmt/format.h>

#include "cpgmatch/dds/convert.hpp"
#include "cpgmatch/dds/profile.hpp"
#include "cpgmatch/dds/security.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/runtime/install_layout.hpp"
#include "cpgmatch/runtime/version.hpp"

namespace cpgmatch::runtime {

void add_version_flag(CLI::App& app, const std::string& program) {
  app.set_version_flag("--version", version_text(program), "print the version and git revision, then exit");
}

void add_dds_flags(CLI::App& app, DdsFlags& flags, const std::string& default_enclave) {
  flags.default_enclave = default_enclave;
  app.add_option("--dds-profile", flags.profile,
                 "Fast DDS profile: local (multicast discovery), cluster (client of discovery servers, UDP only) "
                 "or an XML file (default: $FASTRTPS_DEFAULT_PROFILES_FILE, else local)");
  app.add_option("--discovery-server", flags.discovery_servers,
                 "discovery servers IP:PORT[;IP:PORT...], the position being the server id "
                 "(default: $ROS_DISCOVERY_SERVER)");
  app.add_option("--keystore", flags.keystore,
                 "DDS-Security keystore (deploy/make-study-pki.sh; default: $CPGMATCH_KEYSTORE, else "
                 "$ROS_SECURITY_KEYSTORE when $ROS_SECURITY_ENABLE is true, else no security)");
  app.add_option("--enclave", flags.enclave,
                 "identity in the keystore (default: $ROS_SECURITY_ENCLAVE_OVERRIDE, else " + default_enclave + ")");
}

std::string profiles_file_for(const std::string& profile) {
  if (profile == "local" || profile == "cluster") return (fastdds_profiles_dir() / (profile + ".xml")).string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(profile, ec)) {
    throw InputError(fmt::format("--dds-profile: '{}' is neither local, cluster nor an XML profiles file", profile));
  }
  return profile;
}

void apply_dds_flags(const DdsFlags& flags) {
  dds::ProfileSelection selection;
  if (!flags.profile.empty()) selection.profiles_file = profiles_file_for(flags.profile);
  selection.discovery_servers = flags.discovery_servers;
  dds::select_profile(selection);
  const SecurityChoice choice = choose_security(flags);
  dds::SecuritySelection security;
  security.keystore = choice.keystore;
  security.enclave = choice.enclave;
  try {
    dds::select_security(security);
  } catch (const InputError& e) {
    // A value that came from the environment: say which variable, or the user looks for a flag never given.
    std::string from;
    if (!choice.keystore_from.empty()) from = fmt::format("the keystore is ${}", choice.keystore_from);
    if (!choice.enclave_from.empty()) {
      from += fmt::format("{}the enclave is ${} ('{}')", from.empty() ? "" : ", ", choice.enclave_from,
                          std::getenv(choice.enclave_from.c_str()));
    }
    if (from.empty()) throw;
    throw InputError(fmt::format("{} ({})", e.what(), from));
  }
}

namespace {

const char* nonempty_env(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr && *value != '\0' ? value : nullptr;
}

}  // namespace

SecurityChoice choose_security(const DdsFlags& flags) {
  SecurityChoice c;
  c.keystore = flags.keystore;
  if (c.keystore.empty()) {
    if (const char* env = nonempty_env("CPGMATCH_KEYSTORE")) {
      c.keystore = env;
      c.keystore_from = "CPGMATCH_KEYSTORE";
    } else if (const char* ros = nonempty_env("ROS_SECURITY_KEYSTORE")) {
      // As rcl: the keystore counts only with ROS_SECURITY_ENABLE=true, so a ROS 2 shell that merely names
      // one does not switch security on.
      const char* enable = std::getenv("ROS_SECURITY_ENABLE");
      if (enable != nullptr && std::string(enable) == "true") {
        c.keystore = ros;
        c.keystore_from = "ROS_SECURITY_KEYSTORE";
      }
    }
  }
  c.enclave = flags.enclave;
  if (c.enclave.empty()) {
    if (const char* env = nonempty_env("ROS_SECURITY_ENCLAVE_OVERRIDE")) {
      // ROS 2 enclaves are absolute paths ("/viewer"); ours are the folders under KEYSTORE/enclaves/.
      c.enclave = env[0] == '/' ? env + 1 : env;
      c.enclave_from = "ROS_SECURITY_ENCLAVE_OVERRIDE";
    } else {
      c.enclave = flags.default_enclave;
    }
  }
  return c;
}

std::string resolve_worker_id(const std::string& id, const std::string& fallback) {
  const std::string cn = dds::selected_common_name();
  if (cn.empty()) return id.empty() ? fallback : id;
  if (id.empty()) return cn;
  if (!dds::worker_id_belongs_to(id, cn)) {
    throw InputError(fmt::format("--id '{}': with --keystore the worker id must be the CN of the enclave's certificate "
                                 "('{}' of enclave '{}') or '{}/<suffix>'; the optimizer would count none of its reports",
                                 id, cn, dds::selected_enclave(), cn));
  }
  return id;
}

}  // namespace cpgmatch::runtime
