#pragma once
// Refusals of safety commands (stop, quick stop, disable) for the journal
// (docs/servod.md, "The journal"): the receiver and the command thread
// record each refusal here, and a non-real-time thread (the daemon's
// monitor) takes the lines and writes them to stderr. Rate-limited where it
// is recorded: at most kLinesPerSecond refusals a second are kept, in a
// ring of fixed size; the others are counted, and said in one line
// ("N more ... suppressed") once their second is over. A flood of refused
// stops costs one mutex and a counter each, and the journal a few lines a
// second.

#include <array>
#include <cstdint>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "daemon/servo/command.hpp"
#include "daemon/servo/command_result.hpp"
#include "daemon/servo/fixed_text.hpp"

namespace clm::telemetry {

class SafetyRefusalLog {
 public:
  static constexpr int kLinesPerSecond = 5;

  /// A refusal of a safety command of `kind` from `client` (its `sequence`)
  /// at `utime` [µs since the UNIX epoch], with its result and reason (cut
  /// to the ring's 240 characters; the ack carries it whole). Any thread;
  /// allocates nothing.
  void record(std::int64_t utime, servo::CommandKind kind, std::int64_t client, std::int64_t sequence,
              servo::CommandResult result, std::string_view reason) noexcept;

  /// The lines of the refusals kept since the last call, oldest first:
  /// "refused stop at 2026-11-27T09:47:23.123Z from client 7 (sequence 12):
  /// code 28, <reason>"; then, once the second of suppressed refusals is over
  /// by `now_utime`, "N more refusals of safety commands suppressed in the
  /// second from <time>". Non-real-time.
  std::vector<std::string> take_lines(std::int64_t now_utime);

  /// Every refusal recorded, kept or not.
  std::int64_t recorded() const;

 private:
  struct Entry {
    std::int64_t utime = 0;
    servo::CommandKind kind = servo::CommandKind::kStop;
    std::int64_t client = 0;
    std::int64_t sequence = 0;
    servo::CommandResult result = servo::CommandResult::kRejectedInvalid;
    servo::FixedText<241> reason;
  };
  /// Starts a new second at `utime` when the present one is over; its
  /// suppressed count then waits for take_lines. With mutex_ held.
  void roll(std::int64_t utime) noexcept;

  mutable std::mutex mutex_;
  std::array<Entry, 2 * kLinesPerSecond> kept_{};  ///< two seconds' worth between two take_lines
  std::size_t kept_count_ = 0;
  std::int64_t window_start_utime_ = 0;  ///< the wall-clock second the counts below belong to
  int kept_in_window_ = 0;
  std::int64_t suppressed_ = 0;          ///< in this second
  std::int64_t finished_suppressed_ = 0;  ///< in seconds that are over, not yet said
  std::int64_t finished_since_utime_ = 0;  ///< the first of those seconds
  std::int64_t recorded_ = 0;
};

/// "2026-11-27T09:47:23.123Z" for `utime` [µs since the UNIX epoch].
std::string utc_time_text(std::int64_t utime);

}  // namespace clm::telemetry
