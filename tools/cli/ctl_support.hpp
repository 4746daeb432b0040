#pragma once
// What the subcommands of `clm ctl` share (cmd_ctl.cpp, cmd_ctl_parameters.cpp):
// the global options, the client built from them, and the exit conventions
// (config/exit_status.hpp; 1: refused, no answer in time, LCM not available;
// 2: bad arguments, or several axes answering without --axis). Every error is
// one stderr line "clm ctl: error: ...", printed by main.

#include <CLI/CLI.hpp>
#include <cstdint>
#include <memory>
#include <string>

#include "daemon/servo/command.hpp"
#include "tools/servod_client/client.hpp"

namespace clm::cli {

using Command = servo::Command;
using Kind = servo::CommandKind;

struct CtlOptions {
  std::string lcm_url;
  double timeout_s = 2.0;
  std::string axis;            ///< empty: the only axis answering
  std::int64_t client_id = 0;  ///< 0: servod_client::default_client_id()
  std::string key_file;        ///< empty: clm::default_command_key_path()
};

/// Several axes answer and --axis does not choose: a usage error (exit
/// status 2) naming them.
[[noreturn]] void several_axes(const servod_client::SeveralAxes& e);
/// The client of one subcommand: receives `channels` alone (an LCM regular expression).
servod_client::Options client_options(const CtlOptions& options, const std::string& channels);
/// A client that hears the status and the acks (what sending a command needs).
servod_client::Options command_client_options(const CtlOptions& options);
/// Sends `command` through `client` and returns its ack; no ack:
/// servod_client::NoAck (exit status 1); several axes: exit status 2.
servod_client::Ack send(servod_client::Client& client, const CtlOptions& options, const Command& command);
/// Sends `command` and prints the ack's text on stdout; refused: throws
/// RunTimeFailure with the ack's text (exit status 1, the text on stderr).
void send_command(const CtlOptions& options, const Command& command);
/// Throws RunTimeFailure with the ack's text unless the daemon accepted.
void require_accepted(const servod_client::Ack& ack);
/// The daemon opens files itself, from its own working directory: send absolute paths.
std::string absolute_path(const std::string& path);

/// clm ctl get, set and save (docs/servod.md, "Run-time parameters").
void add_ctl_parameters(CLI::App& ctl, const std::shared_ptr<CtlOptions>& options);

}  // namespace clm::cli
