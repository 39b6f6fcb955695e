// What happens when ODE reports an error or a failed internal assertion during a rollout.
//
// ODE calls its error and debug handlers, then abort()s (debug) or exit(1)s (error) when they return: a model
// value ODE cannot step took the whole process down with SIGABRT. Throwing from the handler is not safe
// either (tried with Debian's libode 0.16: the exception unwinds dWorldStep, a destructor of ODE's job list
// asserts again during the unwinding, and std::terminate aborts). So the handler ends the process itself,
// on purpose and with the reason: it calls the hook set here (which must not return; a rollout process prints
// a `diverged` report with the reason and exits 0), or, without a hook, prints
// "error: the simulation failed: ODE ..." to stderr and exits 1. Rollouts run one per process
// (cpgmatch-sim-worker --run-one), so ending the process ends exactly one rollout.
#pragma once

#include <string>

namespace cpgmatch::sim {

// Must not return (it should end the process, e.g. with _exit). `reason`: "ODE INTERNAL ERROR 1: assertion ...".
using OdeFailureHook = void (*)(const std::string& reason);
void set_ode_failure_hook(OdeFailureHook hook);

// Installs the handlers (dSetErrorHandler, dSetDebugHandler); OdePlant calls it once, before ODE runs.
void install_ode_error_handlers();

}  // namespace cpgmatch::sim
