#pragma once
// The settings of the servo cycle that may change while the daemon runs
// (docs/servod.md, "Run-time parameters"): the position loop's gains and
// feedforward, the motion and stop limits, the following-error and force
// limits. The daemon validates a change, the cycle takes it at standstill
// (ServoCycle::execute); everything else is fixed at start-up.

#include "daemon/control/position_controller.hpp"
#include "daemon/control/stop_profile.hpp"
#include "daemon/control/trajectory.hpp"

namespace clm::servo {

struct Tuning {
  control::PidGains pid{};  ///< from control::tune_pid(mass, bandwidth)
  control::FeedforwardParameters feedforward{};
  double following_error_limit_m = 1e-3;
  double force_limit_N = 500.0;
  double saturation_time_limit_s = 0.05;
  control::MotionLimits motion_limits{0.5, 10.0, 2000.0};
  control::StopLimits stop_limits{10.0, 2000.0};
  control::StopLimits quick_stop_limits{10.0, 2000.0};
};

}  // namespace clm::servo
