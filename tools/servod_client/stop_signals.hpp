#pragma once
// SIGINT and SIGTERM for the tools that run something on a daemon (`clm ctl
// jog`, `clm commission --live`): the handler only records the signal (an
// atomic, async-signal-safe); the client's waits (Client::wait_for_state,
// wait_states, wait_for_status) and the tools' own loops read it, throw
// Interrupted, and the tool then stops what it started and gives control
// back before it exits non-zero (docs/servod.md, "The deadman").

#include "tools/servod_client/client.hpp"

namespace clm::servod_client {

/// Installs the handlers for SIGINT and SIGTERM (sigaction, no SA_RESTART).
/// Throws std::system_error when the system refuses.
void install_stop_signals();
/// The first SIGINT or SIGTERM received since install_stop_signals(), 0 for none.
int stop_signal() noexcept;
/// Throws Interrupted naming the signal when one was received.
void throw_if_interrupted();

}  // namespace clm::servod_client
