// Flags shared by the commands that talk to the optimizer service over DDS.
#pragma once

#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cpgmatch/runtime/shared_flags.hpp"

namespace cpgmatch::cli {

struct ServiceFlags {
  int domain = -1;              // -1: $CPGMATCH_DOMAIN, else 0
  bool localhost_only = false;
  double timeout_s = 10.0;
  runtime::DdsFlags dds;       // --dds-profile, --discovery-server
  int resolved_domain() const;  // validates; InputError naming --domain or CPGMATCH_DOMAIN
};

// default_enclave: the DDS-Security identity the command uses without --enclave (operator, viewer).
void add_service_flags(CLI::App* cmd, ServiceFlags& flags, const std::string& default_enclave);

// Terminal study states: done, failed, stopped.
bool is_terminal(const std::string& state);

// One line of progress: completed/budget, best cost, rollouts per second, ETA.
std::string progress_line(const nlohmann::json& state);

}  // namespace cpgmatch::cli
