#include "drivers/sim/motor.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <string>

#include "commutation/classical.hpp"
#include "commutation/elementary.hpp"

namespace clm::sim {
namespace {

constexpr int kMinSubsteps = 10;
// One step() may integrate at most this many substeps (about 500 s of motor
// time at the default 50 µs); longer periods are refused.
constexpr double kMaxSubsteps = 1e7;
// The watchdog trips at the first substep boundary at or after the deadline;
// the tolerance absorbs the rounding of the accumulated time.
constexpr double kWatchdogTolerance_s = 1e-9;
constexpr std::uint32_t kLatchedBits = kStatusFault | kStatusWatchdog | kStatusEndStop | kStatusInvalidSetpoint;

const MotorParameters& validated(const MotorParameters& parameters) {
  parameters.validate();
  return parameters;
}

}  // namespace

SimulatedMotor::SimulatedMotor(const MotorParameters& parameters)
    : parameters_(validated(parameters)),
      truth_(parameters_.electromagnetics, parameters_.mechanics.end_stop_min_m, parameters_.mechanics.end_stop_max_m),
      noise_(parameters_.sensors.noise_seed) {
  reset(0.5 * (parameters_.stroke_min_m + parameters_.stroke_max_m));
}

void SimulatedMotor::reset(double position_m, double velocity_m_per_s) {
  const auto& mechanics = parameters_.mechanics;
  if (!(position_m >= mechanics.end_stop_min_m && position_m <= mechanics.end_stop_max_m) ||
      !std::isfinite(velocity_m_per_s)) {
    throw ParameterError("reset: position " + std::to_string(position_m) + " m outside the end stops [" +
                         std::to_string(mechanics.end_stop_min_m) + ", " + std::to_string(mechanics.end_stop_max_m) +
                         "] m or velocity not finite");
  }
  time_s_ = 0.0;
  position_m_ = position_m;
  velocity_m_per_s_ = velocity_m_per_s;
  disturbance_force_N_ = 0.0;
  in_contact_ = position_m == mechanics.end_stop_min_m || position_m == mechanics.end_stop_max_m;
  setpoints_.fill(DriveSetpoint{});
  commanded_currents_.fill(PhaseCurrentSetpoint{});
  enable_requested_ = false;
  last_command_time_s_ = 0.0;
  latched_ = 0;
  limited_in_last_step_ = false;
  end_stop_collisions_ = 0;
  last_impact_speed_m_per_s_ = 0.0;
  current_limited_substeps_ = 0;
  currents_A_.setZero(2 * coil_sets());
  update_outputs();
}

bool SimulatedMotor::drive_active() const noexcept { return enable_requested_ && latched_ == 0; }

void SimulatedMotor::latch_fault(std::uint32_t bits) noexcept {
  latched_ |= bits | kStatusFault;
  enable_requested_ = false;
  setpoints_.fill(DriveSetpoint{});
  commanded_currents_.fill(PhaseCurrentSetpoint{});
}

CommandResult SimulatedMotor::check_command(DriveProfile profile, std::size_t count, bool finite) noexcept {
  CommandResult result = CommandResult::kAccepted;
  if (parameters_.drive.profile != profile) {
    result = CommandResult::kWrongProfile;
  } else if (static_cast<int>(count) != coil_sets()) {
    result = CommandResult::kWrongCoilSetCount;
  } else if (!finite) {
    result = CommandResult::kNotFinite;
  }
  if (result != CommandResult::kAccepted) {
    latch_fault(kStatusInvalidSetpoint);
    update_outputs();
  }
  return result;
}

void SimulatedMotor::take_command(bool enable) noexcept {
  enable_requested_ = enable;
  last_command_time_s_ = time_s_;
  update_outputs();
}

CommandResult SimulatedMotor::command(std::span<const DriveSetpoint> setpoints, bool enable) noexcept {
  const bool finite = std::all_of(setpoints.begin(), setpoints.end(), [](const DriveSetpoint& s) {
    return std::isfinite(s.magnitude_N) && std::isfinite(s.delta_rad);
  });
  const CommandResult result = check_command(DriveProfile::kMagnitudePhase, setpoints.size(), finite);
  if (result != CommandResult::kAccepted) return result;
  std::copy(setpoints.begin(), setpoints.end(), setpoints_.begin());
  take_command(enable);
  return result;
}

CommandResult SimulatedMotor::command_currents(std::span<const PhaseCurrentSetpoint> currents,
                                               bool enable) noexcept {
  const bool finite = std::all_of(currents.begin(), currents.end(), [](const PhaseCurrentSetpoint& c) {
    return std::isfinite(c.ia_A) && std::isfinite(c.ib_A);
  });
  const CommandResult result = check_command(DriveProfile::kPhaseCurrent, currents.size(), finite);
  if (result != CommandResult::kAccepted) return result;
  std::copy(currents.begin(), currents.end(), commanded_currents_.begin());
  take_command(enable);
  return result;
}

bool SimulatedMotor::drive_currents(double position_m, CurrentVector& currents_A) const noexcept {
  const int count = coil_sets();
  currents_A.setZero(2 * count);
  if (!drive_active()) return false;
  const double limit = parameters_.drive.phase_current_limit_A;
  bool limited = false;
  for (int l = 0; l < count; ++l) {
    const auto s = static_cast<std::size_t>(l);
    Eigen::Vector2d phase;
    if (parameters_.drive.profile == DriveProfile::kPhaseCurrent) {
      // The commanded currents as they are (ideal current loop).
      phase << commanded_currents_[s].ia_A, commanded_currents_[s].ib_A;
    } else {
      // The drive's own fixed law, eq. (18)/(19), at the true position.
      phase = drive_phase_currents(parameters_.drive.commutation, setpoints_[s], position_m, truth_.pole_pitch_m());
    }
    const double peak = std::max({std::abs(phase.x()), std::abs(phase.y()), std::abs(phase.x() + phase.y())});
    if (peak > limit) {
      // Scale the coil set's current vector so the largest of |i_a|, |i_b|,
      // |i_c| equals the limit: the electrical angle and the star constraint
      // are kept, the force magnitude saturates.
      phase *= limit / peak;
      limited = true;
    }
    currents_A.segment<2>(2 * l) = phase;
  }
  return limited;
}

double SimulatedMotor::friction_N(double velocity_m_per_s) const noexcept {
  return friction_N(velocity_m_per_s,
                    elementary::tanh(velocity_m_per_s / parameters_.mechanics.friction_smoothing_velocity_m_per_s));
}

double SimulatedMotor::friction_N(double velocity_m_per_s, double friction_tanh) const noexcept {
  const auto& mechanics = parameters_.mechanics;
  return mechanics.viscous_friction_N_s_per_m * velocity_m_per_s + mechanics.coulomb_friction_N * friction_tanh;
}

int SimulatedMotor::substeps(double period_s) const noexcept {
  // The small tolerance keeps 1e-3/5e-5 = 20.000000000000004 at 20 substeps.
  const double ratio = std::ceil(period_s / parameters_.mechanics.integration_step_s - 1e-9);
  if (!(ratio <= kMaxSubsteps)) return -1;  // also NaN
  return std::max(kMinSubsteps, static_cast<int>(ratio));
}

StepResult SimulatedMotor::step(double period_s) noexcept {
  if (!std::isfinite(period_s) || !(period_s > 0.0)) return StepResult::kInvalidPeriod;
  const int count = substeps(period_s);
  if (count < 0) return StepResult::kInvalidPeriod;
  const auto& mechanics = parameters_.mechanics;
  const double h = period_s / count;
  const double inverse_mass = 1.0 / mechanics.translator_mass_kg;
  const double deadline_s = parameters_.drive.watchdog_timeout_s - kWatchdogTolerance_s;
  const double start_s = time_s_;
  limited_in_last_step_ = false;

  for (int k = 0; k < count; ++k) {
    const double t = start_s + k * h;
    if (drive_active() && t - last_command_time_s_ >= deadline_s) latch_fault(kStatusWatchdog);
    if (drive_currents(position_m_, currents_A_)) {
      limited_in_last_step_ = true;
      ++current_limited_substeps_;
    }
    // The direction-dependent force's tanh and the friction's in one call:
    // two lanes of one vector cost what one does, with the bits of two calls.
    const double ratio[2] = {truth_.direction_ratio(velocity_m_per_s_),
                             velocity_m_per_s_ / mechanics.friction_smoothing_velocity_m_per_s};
    double shape[2];
    elementary::tanh_array(ratio, shape, 2);
    const double driving_force_N = truth_.driving_force_N(position_terms(position_m_), shape[0], currents_A_);
    // Semi-implicit (symplectic) Euler: velocity first, then the position
    // with the new velocity.
    velocity_m_per_s_ +=
        h * inverse_mass * (driving_force_N + disturbance_force_N_ - friction_N(velocity_m_per_s_, shape[1]));
    position_m_ += h * velocity_m_per_s_;

    // Hard end stops: the translator stops dead (inelastic); the first impact
    // trips the limit switch.
    bool pushing_into_stop = false;
    if (position_m_ >= mechanics.end_stop_max_m) {
      position_m_ = mechanics.end_stop_max_m;
      pushing_into_stop = velocity_m_per_s_ > 0.0;
    } else if (position_m_ <= mechanics.end_stop_min_m) {
      position_m_ = mechanics.end_stop_min_m;
      pushing_into_stop = velocity_m_per_s_ < 0.0;
    }
    if (pushing_into_stop) {
      if (!in_contact_) {
        ++end_stop_collisions_;
        last_impact_speed_m_per_s_ = std::abs(velocity_m_per_s_);
        latch_fault(kStatusEndStop);
      }
      velocity_m_per_s_ = 0.0;
    }
    in_contact_ = position_m_ == mechanics.end_stop_max_m || position_m_ == mechanics.end_stop_min_m;
  }
  time_s_ = start_s + period_s;
  update_outputs();
  return StepResult::kOk;
}

void SimulatedMotor::update_outputs() noexcept {
  if (drive_active() &&
      time_s_ - last_command_time_s_ >= parameters_.drive.watchdog_timeout_s - kWatchdogTolerance_s) {
    latch_fault(kStatusWatchdog);
  }
  drive_currents(position_m_, currents_A_);
  wrench_ = truth_.wrench(position_terms(position_m_), velocity_m_per_s_, currents_A_);
}

const ElectromagneticTruth::PositionTerms& SimulatedMotor::position_terms(double position_m) noexcept {
  // Bits, not ==: the terms of −0 and +0 need not be the same bits.
  if (!terms_valid_ || std::bit_cast<std::uint64_t>(position_m) != std::bit_cast<std::uint64_t>(terms_.position_m)) {
    truth_.position_terms(position_m, terms_);
    terms_valid_ = true;
  }
  return terms_;
}

SensorFrame SimulatedMotor::sense() noexcept {
  const auto& sensors = parameters_.sensors;
  SensorFrame frame;
  frame.time_s = time_s_;
  // Four draws per frame whatever the noise levels, so the stream stays
  // aligned when one of them is switched off.
  double position = position_m_ + sensors.encoder_noise_m * noise_.normal();
  if (sensors.encoder_resolution_m > 0.0) {
    position = sensors.encoder_resolution_m * std::round(position / sensors.encoder_resolution_m);
  }
  frame.position_m = position;
  for (int q = 0; q < 3; ++q) {
    frame.wrench[q] = wrench_[q] + sensors.force_bias_N_N_Nm[q] + sensors.force_noise_N_N_Nm[q] * noise_.normal();
  }
  return frame;
}

DriveStatus SimulatedMotor::status() const noexcept {
  std::uint32_t word = latched_ & kLatchedBits;
  if (drive_active()) word |= kStatusEnabled;
  if (limited_in_last_step_) word |= kStatusCurrentLimited;
  return DriveStatus{word};
}

void SimulatedMotor::latch_internal_fault() noexcept {
  latch_fault(kStatusFault);
  update_outputs();
}

void SimulatedMotor::clear_fault() noexcept {
  latched_ = 0;
  enable_requested_ = false;
  setpoints_.fill(DriveSetpoint{});
  commanded_currents_.fill(PhaseCurrentSetpoint{});
  update_outputs();
}

TruthState SimulatedMotor::truth() const noexcept {
  TruthState state;
  state.time_s = time_s_;
  state.position_m = position_m_;
  state.velocity_m_per_s = velocity_m_per_s_;
  state.currents_A = currents_A_;
  state.wrench = wrench_;
  state.friction_N = friction_N(velocity_m_per_s_);
  state.end_stop_collisions = end_stop_collisions_;
  state.last_impact_speed_m_per_s = last_impact_speed_m_per_s_;
  state.current_limited_substeps = current_limited_substeps_;
  return state;
}

}  // namespace clm::sim
