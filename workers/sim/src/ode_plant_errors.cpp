#include <unistd.h>

#include <atomic>
#include <cstdarg>
#include <cstdio>

#include <ode/ode.h>

#include "cpgmatch/sim/ode_errors.hpp"

namespace cpgmatch::sim {
namespace {

std::atomic<OdeFailureHook> g_hook{nullptr};

[[noreturn]] void fail(const char* kind, int number, const char* format, va_list args) {
  char text[1024];
  std::vsnprintf(text, sizeof(text), format, args);
  const std::string reason = std::string("ODE ") + kind + " " + std::to_string(number) + ": " + text;
  if (const OdeFailureHook hook = g_hook.load()) hook(reason);
  std::fprintf(stderr, "error: the simulation failed: %s\n", reason.c_str());
  std::fflush(stderr);
  std::fflush(stdout);
  _exit(1);  // not exit(): other threads may be inside ODE, and static destructors would touch it
}

void on_error(int number, const char* format, va_list args) { fail("ERROR", number, format, args); }
void on_debug(int number, const char* format, va_list args) { fail("INTERNAL ERROR", number, format, args); }

}  // namespace

void set_ode_failure_hook(OdeFailureHook hook) { g_hook.store(hook); }

void install_ode_error_handlers() {
  dSetErrorHandler(on_error);
  dSetDebugHandler(on_debug);
}

}  // namespace cpgmatch::sim
