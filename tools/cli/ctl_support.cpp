#include "tools/cli/ctl_support.hpp"

#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "daemon/telemetry/telemetry.hpp"

namespace clm::cli {

void several_axes(const servod_client::SeveralAxes& e) {
  throw std::invalid_argument(e.what());  // not a RunTimeFailure: --axis must choose (exit status 2)
}

void require_accepted(const servod_client::Ack& ack) {
  if (!ack.accepted) throw RunTimeFailure(ack.text);
}

servod_client::Options client_options(const CtlOptions& options, const std::string& channels) {
  servod_client::Options client;
  client.lcm_url = options.lcm_url;
  client.channels = channels;
  client.axis = options.axis;
  client.client_id = options.client_id;
  client.key_file = options.key_file;
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
  }
}

void send_command(const CtlOptions& options, const Command& command) {
  servod_client::Client client(command_client_options(options));  // no LCM: servod_client::Error, exit status 1
  const servod_client::Ack ack = send(client, options, command);
  require_accepted(ack);
  std::printf("%s\n", ack.text.c_str());
}

std::string absolute_path(const std::string& path) { return std::filesystem::absolute(path).lexically_normal().string(); }

}  // namespace clm::cli
