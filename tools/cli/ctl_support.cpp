#include "tools/cli/ctl_support.hpp"

#include <cstdio>
#include <filesystem>

#include "daemon/telemetry/telemetry.hpp"

namespace clm::cli {

void fail_quietly() { throw CLI::RuntimeError(1); }

void several_axes(const servod_client::SeveralAxes& e) {
  std::fprintf(stderr, "clm ctl: %s\n", e.what());
  throw CLI::RuntimeError(2);
}

servod_client::Options client_options(const CtlOptions& options, const std::string& channels) {
  servod_client::Options client;
  client.lcm_url = options.lcm_url;
  client.channels = channels;
  client.axis = options.axis;
  client.client_id = options.client_id;
  return client;
}

servod_client::Options command_client_options(const CtlOptions& options) {
  // The status names axis, session and the control holder; the ack answers.
  return client_options(options, std::string("(") + telemetry::kStatusChannel + "|" + telemetry::kCommandAckChannel + ")");
}

servod_client::Ack send(servod_client::Client& client, const CtlOptions& options, const Command& command) {
  try {
    return client.send(command, options.timeout_s);
  } catch (const servod_client::SeveralAxes& e) {
    several_axes(e);
  } catch (const servod_client::NoAck& e) {
    std::fprintf(stderr, "clm ctl: %s\n", e.what());
    fail_quietly();
  }
}

void send_command(const CtlOptions& options, const Command& command) {
  servod_client::Client client(command_client_options(options));  // no LCM: exit status 2
  const servod_client::Ack ack = send(client, options, command);
  std::printf("%s\n", ack.text.c_str());
  if (!ack.accepted) fail_quietly();
}

std::string absolute_path(const std::string& path) { return std::filesystem::absolute(path).lexically_normal().string(); }

}  // namespace clm::cli
