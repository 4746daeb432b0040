#pragma once
// Helpers for daemon tests: the default configuration on the virtual clock.

#include <string>

#include "daemon/servod/servo_daemon.hpp"

namespace clm::test {

inline std::string source_path(const std::string& relative) { return std::string(CLM_SOURCE_DIR) + "/" + relative; }

/// config/servod.yaml with the virtual clock and no telemetry.
inline servod::ServodConfig virtual_config(const std::string& file = "config/servod.yaml") {
  auto config = servod::load_servod_config(source_path(file));
  config.loop.clock = servod::ClockMode::kVirtual;
  config.telemetry.enabled = false;
  return config;
}

inline servod::CommandReply command(servod::ServoDaemon& daemon, servod::DaemonCommand::Kind kind,
                                    std::int64_t cycles = 1) {
  servod::DaemonCommand c;
  c.kind = kind;
  auto reply = daemon.submit(c);
  daemon.run_cycles(cycles);
  return reply;
}

}  // namespace clm::test
