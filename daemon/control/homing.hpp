#pragma once
// Homing (docs/servod.md, "Homing"): the settings of the method, and the
// search motion, a jerk-limited start to a constant velocity that runs
// until the drive latches its reference or the search distance is used up.
// Numerical only: no I/O, no allocation.

#include <cstdint>

#include "daemon/control/commutation_finding.hpp"
#include "daemon/control/stop_profile.hpp"

namespace clm::control {

enum class HomingMethod : std::uint8_t {
  /// An absolute encoder: the axis is homed from the first cycle.
  kNone,
  /// An incremental encoder with index marks: commutation finding, then a
  /// search in `direction` until the drive latches the next index mark.
  kIndex,
  /// The same with the reference switch's edge as the latch event.
  kReferenceSwitch,
  /// Commutation finding, then a search with the force limited to
  /// hard_stop_force_N until the following error passes
  /// hard_stop_following_error_m (the axis stopped at the hard stop): that
  /// reading is the reference; then back off by back_off_m.
  kHardStop,
};
/// "none", "index", "reference_switch", "hard_stop".
const char* name(HomingMethod method) noexcept;

struct HomingSettings {
  HomingMethod method = HomingMethod::kNone;
  /// +1: search towards soft_limit_max_m; −1: towards soft_limit_min_m.
  int direction = 1;
  /// The search's constant velocity [m/s], > 0; its start and stop use the
  /// stop limits (jerk-limited).
  double search_velocity_m_per_s = 0.005;
  /// The longest search [m], > 0: no event within it is fault 217.
  double search_distance_m = 0.05;
  /// The axis position of the event the drive latches (an index mark or the
  /// switch's edge) [m]: the reference the calibration and model files were made against.
  double reference_position_m = 0.0;
  /// kReferenceSwitch only: after the switch's edge, the search goes on to
  /// the encoder's next index mark, which is the reference (the switch says
  /// which mark, the mark where).
  bool index_in_switch = false;
  /// kHardStop: the force the search may push with [N], > 0, and the
  /// following error that says it stopped at the hard stop [m], > 0 (below
  /// control.following_error_limit_m); the distance it backs off by [m], > 0.
  double hard_stop_force_N = 40.0;
  double hard_stop_following_error_m = 2e-4;
  double back_off_m = 0.002;
  bool latches() const noexcept { return method == HomingMethod::kIndex || method == HomingMethod::kReferenceSwitch; }
  CommutationFindingSettings finding;
  /// The encoder reads an unknown offset at power-up.
  bool incremental() const noexcept { return method != HomingMethod::kNone; }
  /// Throws std::invalid_argument naming the setting.
  void validate() const;
};

/// The search motion: from rest at `start_m`, up to `velocity_m_per_s`
/// (signed) within `limits` and on at it. In the frame moving at that
/// velocity the start is a stop from −velocity, so the stop profile's
/// jerk-limited planning gives the start.
class SearchProfile {
 public:
  SearchProfile() = default;
  static SearchProfile plan(double start_m, double velocity_m_per_s, const StopLimits& limits) noexcept;
  ReferenceSample sample(double t_s) const noexcept;
  double start_m() const noexcept { return start_m_; }

 private:
  double start_m_ = 0.0, velocity_m_per_s_ = 0.0;
  StopProfile relative_;
};

}  // namespace clm::control
