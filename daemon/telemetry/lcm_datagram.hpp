#pragma once
// clm-servod's own reader of LCM's udpm wire format (docs/servod.md,
// "Receiving commands"). liblcm sizes its reassembly buffer from the payload
// size a fragment's header claims (lcm_frag_buf_new), so one 1 kB datagram
// claiming 2^28 bytes made it allocate, and under mlockall lock, 256 MB. The
// daemon therefore never receives through liblcm: it publishes with liblcm
// and reads the group with a socket of its own (UdpmReceiver), checking each
// datagram's header here before anything is sized from it.
//
// The wire format (all big-endian):
//   short message: magic "LC02" (0x4c433032), u32 sequence, channel (NUL-
//                  terminated, at most 63 bytes), payload;
//   fragment:      magic "LC03" (0x4c433033), u32 sequence, u32 payload size,
//                  u32 fragment offset, u16 fragment number, u16 fragment
//                  count, then (fragment 0) the channel, then data.
// liblcm sends a message as fragments only when channel and payload exceed
// 65499 bytes; every message the daemon accepts is far smaller
// (kMaxAcceptedPayloadBytes), so every fragment belongs to a message larger
// than any the daemon accepts: it is dropped, unread, and counted.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace clm::telemetry {

inline constexpr std::uint32_t kLcmShortMagic = 0x4c433032;     // "LC02"
inline constexpr std::uint32_t kLcmFragmentMagic = 0x4c433033;  // "LC03"
/// liblcm's limit for channel, NUL and payload in one short message (Linux).
inline constexpr std::size_t kLcmShortMessageMaxBytes = 65499;
/// LCM's longest channel name, without the NUL.
inline constexpr std::size_t kLcmMaxChannelBytes = 63;

/// What check_lcm_datagram found.
enum class DatagramKind : std::uint8_t {
  kShort,     ///< a short message: channel and payload are set
  kFragment,  ///< a fragment (LC03): dropped unread; payload_bytes is what its header claims
  kNotLcm,    ///< too short, another magic, a channel without its NUL or over 63 bytes
};

struct LcmDatagram {
  DatagramKind kind = DatagramKind::kNotLcm;
  std::string_view channel;                ///< kShort: into the datagram
  std::span<const std::uint8_t> payload;   ///< kShort: into the datagram
  std::uint32_t claimed_bytes = 0;         ///< kFragment: the header's payload size (never used to size anything)
};

/// Reads the header of one received datagram. Pure, no allocation.
LcmDatagram check_lcm_datagram(std::span<const std::uint8_t> datagram) noexcept;

/// The parts of a udpm URL the receiver needs.
struct UdpmAddress {
  std::string group;            ///< dotted IPv4 multicast group
  std::uint16_t port = 0;
  int receive_buffer_bytes = 0;  ///< recv_buf_size, else 4 MiB (with_receive_buffer's)
};

/// Parses "udpm://GROUP:PORT[?opt=value&...]" (LCM's defaults
/// 239.255.76.67:7667 when a part is missing). Throws std::invalid_argument
/// naming the URL for another provider, a group that is not IPv4 multicast,
/// or a port or recv_buf_size out of range.
UdpmAddress parse_udpm_url(const std::string& url);

/// A UDP socket bound to the group's port and joined to the group (the
/// same datagrams liblcm would receive). Non-real-time threads only.
class UdpmReceiver {
 public:
  /// Throws std::runtime_error naming the URL and the failing call.
  explicit UdpmReceiver(const UdpmAddress& address);
  ~UdpmReceiver();
  UdpmReceiver(const UdpmReceiver&) = delete;
  UdpmReceiver& operator=(const UdpmReceiver&) = delete;

  /// Waits up to `timeout_ms` for a datagram and copies it into `buffer`
  /// (truncated to its size: a datagram longer than the buffer is reported
  /// as its full length, so the caller can drop it). Returns the datagram's
  /// length, 0 when none came (or on EINTR), -1 on a socket error.
  long receive(std::span<std::uint8_t> buffer, int timeout_ms) noexcept;

 private:
  int fd_ = -1;
};

}  // namespace clm::telemetry
