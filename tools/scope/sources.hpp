#pragma once
// Where `clm scope` takes its states from: the live CLM_SERVO_STATE stream
// of a running clm-servod (only what carries the operators' mac, as every
// client: tools/servod_client/client.hpp), or an LCM log replayed at its own
// pace (or faster). Both give the same records.

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "daemon/servo/cycle_record.hpp"

namespace clm::servod_client {
class Client;
}

namespace clm::scope {

class StateSource {
 public:
  virtual ~StateSource() = default;
  /// Appends the states that arrived (or became due) since the last call.
  virtual void take(std::vector<servo::CycleRecord>& out) = 0;
  /// True when no state will come any more (the end of a log).
  virtual bool exhausted() const = 0;
  /// "live udpm://…" / "log run.lcm at 1x", and what was dropped.
  virtual std::string describe() const = 0;
};

/// The live stream on `lcm_url`, checked with the key in `key_file` (empty:
/// the default key file). Throws as servod_client::Client.
std::unique_ptr<StateSource> live_source(const std::string& lcm_url, const std::string& key_file);

/// The states of the log at `path` (lcmlog::read_servo_states; throws as it
/// does), replayed at `speed` times their own pace (0: all at once). A gap
/// in t_s above 1 s, or t_s going back (the next run in the log), is played
/// as one period.
std::unique_ptr<StateSource> log_source(const std::string& path, double speed);

}  // namespace clm::scope
