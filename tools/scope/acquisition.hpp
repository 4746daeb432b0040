#pragma once
// The acquisition of `clm scope`: samples of chosen channels in, the window
// to show out, as an oscilloscope does it (docs/scope.md). A trigger on one
// channel (a level crossed on an edge) fixes where the window sits; the
// window keeps `pre_trigger` of itself before the trigger. Modes:
//   auto:   a triggered window when a trigger comes, else (after a window
//           length without one) the latest window, rolling;
//   normal: only triggered windows; the last one stays until the next;
//   single: one triggered window, then nothing until arm().
// Pure: no I/O, no clock; time is the samples' own t_s.

#include <cstddef>
#include <cstdint>
#include <deque>
#include <limits>
#include <span>
#include <string>
#include <vector>

namespace clm::scope {

enum class TriggerEdge { kRising, kFalling, kEither };
enum class TriggerMode { kAuto, kNormal, kSingle };

/// "rising", "falling", "either" / "auto", "normal", "single";
/// std::invalid_argument otherwise.
TriggerEdge parse_edge(const std::string& name);
TriggerMode parse_mode(const std::string& name);
const char* name(TriggerEdge edge) noexcept;
const char* name(TriggerMode mode) noexcept;

struct Trigger {
  int channel = -1;   ///< index of the trigger channel; −1: none (auto mode rolls)
  double level = 0.0; ///< in the channel's unit
  TriggerEdge edge = TriggerEdge::kRising;
  TriggerMode mode = TriggerMode::kAuto;
  double pre_trigger = 0.2;  ///< fraction of the window before the trigger, 0..1
};

/// A window of samples: times and, per channel, values.
struct Window {
  std::vector<double> t_s;
  std::vector<std::vector<double>> values;  ///< values[channel][sample]
  double start_s = 0.0;  ///< the window's span [start_s, start_s + length_s]
  double length_s = 0.0;
  /// Time of the trigger (interpolated between the samples that crossed the
  /// level) [s]; NaN for a rolling window.
  double trigger_t_s = std::numeric_limits<double>::quiet_NaN();
  std::int64_t number = 0;  ///< 1, 2, ... for triggered windows; 0 for a rolling one
  /// States that belong in the window but never arrived: gaps in the
  /// samples' sequence numbers (the daemon's cycle) beyond the smallest step
  /// seen, those of the missing ones whose time falls within the window.
  std::int64_t missing = 0;
  bool triggered() const { return number > 0; }
  bool empty() const { return t_s.empty(); }
};

/// Where the acquisition is.
enum class Phase {
  kFilling,     ///< armed, but the part before a trigger is not yet recorded: no trigger counts
  kArmed,       ///< waiting for a trigger
  kCollecting,  ///< triggered, filling the part after the trigger
  kHeld,        ///< single: a window captured, not rearmed
  kPaused,      ///< samples ignored; the shown window stays
};
const char* name(Phase phase) noexcept;

class Acquisition {
 public:
  /// `channels` values per sample; windows of `window_s` [s] > 0. Throws
  /// std::invalid_argument for a trigger channel not below `channels`, a
  /// pre_trigger outside 0..1 or a window not above 0.
  Acquisition(std::size_t channels, double window_s, Trigger trigger);

  /// One sample at time `t_s` with sequence number `sequence` (the daemon's
  /// cycle; values.size() == channels). A time or a sequence number not
  /// above the last one (a daemon restarted, a log of several runs) starts
  /// the history afresh. NaN values never trigger.
  void push(double t_s, std::int64_t sequence, std::span<const double> values);

  /// The window to show: the latest triggered one, or rolling (auto; cut
  /// from the history when asked for, not at every sample).
  const Window& shown() const;
  /// kFilling while armed and the pre-trigger part since arming (or the
  /// last capture's hold-off) is not yet recorded.
  Phase phase() const;
  const Trigger& trigger() const { return trigger_; }
  double window_s() const { return window_s_; }
  std::int64_t captures() const { return captures_; }

  /// Pause (samples ignored) or run again (rearmed, history kept).
  void set_paused(bool paused);
  /// Rearms: the next trigger makes a window (single after a capture).
  void arm();
  void set_mode(TriggerMode mode);
  void set_level(double level);
  void set_edge(TriggerEdge edge);
  /// A new window length (> 0); rearms.
  void set_window(double window_s);

 private:
  struct Sample {
    double t_s;
    std::int64_t sequence;
    std::vector<double> values;
  };
  double pre_s() const { return trigger_.pre_trigger * window_s_; }
  double post_s() const { return window_s_ - pre_s(); }
  /// A trigger at `t_s` has its pre-trigger part recorded since arming and
  /// lies after the hold-off.
  bool may_trigger_at(double t_s) const { return t_s - pre_s() >= armed_at_s_ && t_s >= next_allowed_s_; }
  Window cut(double start_s, double trigger_t_s) const;
  void look_for_trigger();
  void trim();

  std::size_t channels_;
  double window_s_;
  Trigger trigger_;
  std::deque<Sample> history_;
  Phase phase_ = Phase::kArmed;
  double armed_at_s_ = std::numeric_limits<double>::quiet_NaN();  ///< first sample time since arming
  double trigger_t_s_ = 0.0;  ///< of the window being collected
  double next_allowed_s_ = -std::numeric_limits<double>::infinity();  ///< a trigger must come after this (hold-off)
  mutable Window shown_;
  mutable bool roll_due_ = false;  ///< shown_ is to be the latest window (auto, no trigger)
  std::int64_t captures_ = 0;
};

}  // namespace clm::scope

namespace clm::scope {

/// The window `steps` places up (+) or down (−) the 1-2-5 sequence of time
/// bases from `window_s` (0.5 s → +1 → 1 s, −1 → 0.2 s); a window off the
/// sequence goes to the next one on it. Within 1 ms .. 100 s.
double step_window(double window_s, int steps);

}  // namespace clm::scope
