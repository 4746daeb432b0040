#pragma once
// The run-time parameters the cycle uses, and a change on its way to it
// (docs/servod.md, "Run-time parameters"). `get` answers from the values in
// use; `set` validates a change as the configuration would (parameters.hpp)
// and hands the whole tuning to the cycle; the cycle's answer (`settle`)
// commits or drops it. Moves are planned against the committed values
// (`planning_settings`), and refused while a change is on its way, so that no
// move is ever checked against limits the cycle does not have. Any
// non-real-time thread; never the loop's (one mutex).

#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>

#include "daemon/servo/command_result.hpp"
#include "daemon/servo/servo_cycle.hpp"
#include "daemon/servod/parameters.hpp"

namespace clm::servod {

class ParameterStore {
 public:
  /// `base`: the configuration's settings; `rate_hz`: the loop rate;
  /// `plant`: what the motor file describes (ServodConfig::plant).
  ParameterStore(const servo::ServoSettings& base, double rate_hz, const control::PlantModel& plant,
                 const RuntimeValues& initial)
      : base_(base), rate_hz_(rate_hz), plant_(plant), values_(initial) {}

  /// The values the cycle uses now.
  RuntimeValues values() const;
  /// A change was handed to the cycle and it has not answered yet.
  bool change_pending() const;
  /// The configuration's settings with the values the cycle uses.
  servo::ServoSettings planning_settings() const;

  struct Answer {
    servo::CommandResult result = servo::CommandResult::kRejectedInvalid;
    std::string text;  ///< get: "key = value unit"; a refusal: the reason ("" when describe() says it all)
  };
  /// get_parameter.
  Answer get(std::string_view key) const;
  /// set_parameter from `client`'s command `sequence`: refused while another
  /// change is pending or when the change is invalid; else `queue` hands the
  /// whole tuning to the cycle (under the store's lock, so that no second
  /// change overtakes it) and, when it did, the change waits for `settle`.
  /// `queue` runs under the store's lock: it must not call the store.
  Answer set(std::string_view key, double value, std::int64_t sequence, std::int64_t client,
             const std::function<servo::CommandResult(const servo::Tuning&)>& queue);
  /// The cycle's answer to command `sequence` of `client`: commits or drops
  /// the pending change it belongs to. True when the feedforward in use changed.
  bool settle(std::int64_t sequence, std::int64_t client, servo::CommandResult result);
  /// load_feedforward, which the cycle takes without condition.
  void set_feedforward(const control::FeedforwardParameters& feedforward);

 private:
  const servo::ServoSettings base_;
  const double rate_hz_;
  const control::PlantModel plant_;
  mutable std::mutex mutex_;  // guards the three below
  RuntimeValues values_;                  // what the cycle uses
  std::optional<RuntimeValues> pending_;  // handed to the cycle, not yet answered
  std::int64_t pending_sequence_ = 0, pending_client_ = 0;
};

}  // namespace clm::servod
