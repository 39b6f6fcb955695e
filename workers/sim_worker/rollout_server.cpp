#include "rollout_server.hpp"

#include <fcntl.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cpgmatch/domain/report_json.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/sim/ode_errors.hpp"
#include "rollout_request.hpp"
#include "spec_cache.hpp"

namespace cpgmatch::worker {
namespace {

int g_answers = -1;  // the fd answers go to (the stdout this process was started with)

void write_answer(const nlohmann::json& answer) {
  const std::string line = answer.dump() + "\n";
  std::size_t written = 0;
  while (written < line.size()) {
    const ssize_t n = write(g_answers, line.data() + written, line.size() - written);
    if (n > 0) {
      written += static_cast<std::size_t>(n);
    } else if (errno != EINTR) {
      _exit(kExitFailure);  // the slot is gone: nobody to serve
    }
  }
}

// ODE cannot step on: this rollout diverged. The process cannot go on (ODE_errors.hpp), so it answers with
// a diverged report that says so and exits; the slot starts a fresh process for its next candidate.
[[noreturn]] void answer_ode_failure(const std::string& reason) {
  domain::RolloutReport r;
  r.outcome = domain::Outcome::kDiverged;
  r.error = "simulation failed: " + reason;
  write_answer({{"report", domain::to_json(r)}, {"process_ends", true}});
  _exit(kExitOk);
}

struct TestFault {
  std::string kind;
  std::uint64_t seed = 0;
};

std::optional<TestFault> test_fault_from_environment() {
  const char* text = std::getenv("CPGMATCH_TEST_ROLLOUT_FAULT");
  if (!text) return std::nullopt;
  const std::string s = text;
  const std::size_t colon = s.find(':');
  if (colon == std::string::npos) return std::nullopt;
  return TestFault{s.substr(0, colon), std::stoull(s.substr(colon + 1))};
}

void inject(const TestFault& fault) {
  if (fault.kind == "abort") std::abort();
  if (fault.kind == "ode_failure") answer_ode_failure("ODE INTERNAL ERROR (injected by CPGMATCH_TEST_ROLLOUT_FAULT)");
  if (fault.kind == "hang") {
    while (true) pause();
  }
  if (fault.kind == "garbage") {
    const std::string garbage = "this is not an answer\n";
    if (write(g_answers, garbage.data(), garbage.size()) < 0) _exit(kExitFailure);
  }
}

std::uint64_t spec_key_of(const nlohmann::json& request) {
  const std::string hex = request.at("spec_key").get<std::string>();
  std::size_t used = 0;
  const std::uint64_t key = std::stoull(hex, &used, 16);
  if (used != hex.size() || hex.empty()) throw InputError(fmt::format("rollout request: spec_key '{}' is not hex", hex));
  return key;
}

// The spec a request runs: the one kept under its key, else the one it carries (parsed once, then kept);
// null when it carries none and this process holds none.
std::shared_ptr<const study::StudySpec> spec_for(const nlohmann::json& request, SpecCache& specs) {
  const std::uint64_t key = spec_key_of(request);
  if (auto kept = specs.find(key)) return kept;
  if (!request.contains("spec")) return nullptr;
  auto parsed = std::make_shared<const study::StudySpec>(
      study::StudySpec::from_json_text(request.at("spec").get<std::string>(), "rollout request"));
  if (parsed->key() != key) {
    throw InputError(fmt::format("rollout request: its spec has key {}, not {}", study::spec_key_hex(parsed->key()),
                                 study::spec_key_hex(key)));
  }
  specs.keep(parsed);
  return parsed;
}

nlohmann::json answer_to(const std::string& line, SpecCache& specs, const std::optional<TestFault>& fault) {
  try {
    const nlohmann::json request = nlohmann::json::parse(line);
    const auto spec = spec_for(request, specs);
    if (!spec) return {{"unknown_spec", request.at("spec_key")}};
    if (fault && request.at("seed").get<std::uint64_t>() == fault->seed) inject(*fault);
    return {{"report", run_rollout(*spec, request)}};
  } catch (const nlohmann::json::exception& e) {
    return {{"error", fmt::format("rollout request: {}", e.what())}};
  } catch (const std::logic_error& e) {  // std::stoull of a bad key
    return {{"error", fmt::format("rollout request: bad spec_key: {}", e.what())}};
  } catch (const InputError& e) {
    return {{"error", e.what()}};
  }
}

}  // namespace

int serve_rollouts() {
  // As for --run-one (main.cpp): worthless once the worker is gone, SIGKILL included.
  const pid_t parent = getppid();
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (parent == 1 || getppid() != parent) return kExitFailure;
  g_answers = fcntl(STDOUT_FILENO, F_DUPFD_CLOEXEC, 3);
  if (g_answers < 0 || dup2(STDERR_FILENO, STDOUT_FILENO) < 0) return kExitFailure;
  sim::set_ode_failure_hook(answer_ode_failure);
  const std::optional<TestFault> fault = test_fault_from_environment();
  SpecCache specs;
  for (std::string line; std::getline(std::cin, line);) {
    if (!line.empty()) write_answer(answer_to(line, specs, fault));
  }
  return kExitOk;
}

}  // namespace cpgmatch::worker
