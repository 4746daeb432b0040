// libFuzzer harness: the receive path of every LCM message the daemon and its
// clients read from the network (daemon/telemetry/wire_check.hpp).
//
// Input bytes: [0] selects the message type (mod 5), the rest is the
// datagram. The datagram goes through decode_checked exactly as a received
// one does. Invariant: a datagram that is accepted encodes back to the same
// bytes, so the check and lcm-gen's decode agree on every field; a refused
// one must not crash, hang or allocate without bound on the way.

#include <cstring>
#include <span>
#include <vector>

#include "daemon/telemetry/wire_check.hpp"
#include "fuzz_support.hpp"

using clm::fuzz::require;

namespace {

template <typename Message>
void check(std::span<const std::uint8_t> datagram) {
  Message message;
  if (!clm::telemetry::decode_checked(datagram, message).empty()) return;
  std::vector<std::uint8_t> again(static_cast<std::size_t>(message.getEncodedSize()));
  require(message.encode(again.data(), 0, static_cast<int>(again.size())) == static_cast<int>(again.size()),
          "encode of an accepted message failed");
  require(again.size() == datagram.size() && std::memcmp(again.data(), datagram.data(), again.size()) == 0,
          "an accepted datagram does not encode back to itself", Message::getTypeName());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::span<const std::uint8_t> datagram(data + 1, size - 1);
  switch (data[0] % 5) {
    case 0: check<clm_lcm::servo_command_t>(datagram); break;
    case 1: check<clm_lcm::servo_command_ack_t>(datagram); break;
    case 2: check<clm_lcm::servo_state_t>(datagram); break;
    case 3: check<clm_lcm::servo_status_t>(datagram); break;
    default: check<clm_lcm::servo_event_t>(datagram); break;
  }
  return 0;
}
