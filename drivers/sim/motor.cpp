#include "drivers/sim/motor.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <string>

#include "commutation/classical.hpp"
#include "commutation/elementary.hpp"
#include "commutation/types.hpp"

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
      noise_(parameters_.sensors.noise_seed),
      disturbance_(parameters_.mechanics.force_disturbance),
      current_loop_(parameters_.drive.current_loop) {
  // The interpolation error's phases: a stream of their own, so that the
  // noise draws per frame stay those of a motor without it.
  RandomStream phases(stream_seed(parameters_.sensors.noise_seed, 7));
  interpolation_phase_rad_[0] = kTwoPi * phases.uniform();
  interpolation_phase_rad_[1] = kTwoPi * phases.uniform();
  RandomStream offset(parameters_.sensors.encoder_offset_seed);
  encoder_offset_m_ = parameters_.sensors.encoder_power_up_offset_max_m * (2.0 * offset.uniform() - 1.0);
  reset(0.5 * (parameters_.stroke_min_m + parameters_.stroke_max_m));
}

void SimulatedMotor::require_between_stops(const char* what, double position_m, double velocity_m_per_s) const {
  const auto& mechanics = parameters_.mechanics;
  if (!(position_m >= mechanics.end_stop_min_m && position_m <= mechanics.end_stop_max_m) ||
      !std::isfinite(velocity_m_per_s)) {
    throw ParameterError(std::string(what) + ": position " + std::to_string(position_m) +
                         " m outside the end stops [" + std::to_string(mechanics.end_stop_min_m) + ", " +
                         std::to_string(mechanics.end_stop_max_m) + "] m or velocity not finite");
  }
}

void SimulatedMotor::reset(double position_m, double velocity_m_per_s) {
  require_between_stops("reset", position_m, velocity_m_per_s);
  const auto& mechanics = parameters_.mechanics;
  time_s_ = 0.0;
  position_m_ = position_m;
  velocity_m_per_s_ = velocity_m_per_s;
  encoder_position_m_ = position_m;
  encoder_velocity_m_per_s_ = velocity_m_per_s;
  history_time_s_[0] = 0.0;
  history_position_m_[0] = position_m;
  history_next_ = 1;
  history_count_ = 1;
  disturbance_.reset();
  current_loop_.reset(2 * coil_sets());
  reference_A_.setZero(2 * coil_sets());
  pending_count_ = 0;
  disturbance_force_N_ = 0.0;
  in_contact_ = position_m == mechanics.end_stop_min_m || position_m == mechanics.end_stop_max_m;
  setpoints_.fill(DriveSetpoint{});
  commanded_currents_.fill(PhaseCurrentSetpoint{});
  enable_requested_ = false;
  enabled_at_s_ = 0.0;
  last_command_time_s_ = 0.0;
  latched_ = 0;
  latch_armed_ = latch_caught_ = latch_fresh_ = false;
  limited_in_last_step_ = false;
  end_stop_collisions_ = 0;
  last_impact_speed_m_per_s_ = 0.0;
  current_limited_substeps_ = 0;
  currents_A_.setZero(2 * coil_sets());
  step_mean_currents_A_.setZero(2 * coil_sets());
  step_mean_position_m_ = position_m;
  update_outputs();
}

void SimulatedMotor::push_to(double position_m, double velocity_m_per_s) {
  require_between_stops("push_to", position_m, velocity_m_per_s);
  const auto& mechanics = parameters_.mechanics;
  position_m_ = encoder_position_m_ = position_m;
  velocity_m_per_s_ = encoder_velocity_m_per_s_ = velocity_m_per_s;
  // The encoder's history starts again here: no reading interpolates across the push.
  history_time_s_[0] = time_s_;
  history_position_m_[0] = position_m;
  history_next_ = 1;
  history_count_ = 1;
  in_contact_ = position_m == mechanics.end_stop_min_m || position_m == mechanics.end_stop_max_m;
  step_mean_position_m_ = position_m;
  update_outputs();
}

bool SimulatedMotor::drive_active() const noexcept {
  return enable_requested_ && latched_ == 0 &&
         time_s_ - enabled_at_s_ >= parameters_.drive.enable_delay_s - kWatchdogTolerance_s;
}

void SimulatedMotor::latch_fault(std::uint32_t bits) noexcept {
  latched_ |= bits | kStatusFault;
  enable_requested_ = false;
  setpoints_.fill(DriveSetpoint{});
  commanded_currents_.fill(PhaseCurrentSetpoint{});
  pending_count_ = 0;
}

double SimulatedMotor::motor_side_mass_kg() const noexcept {
  const auto& mechanics = parameters_.mechanics;
  return payload_kg_ + (mechanics.flexible_mode.rigid()
                            ? mechanics.translator_mass_kg
                            : mechanics.translator_mass_kg * (1.0 - mechanics.flexible_mode.encoder_mass_fraction));
}

void SimulatedMotor::set_payload_kg(double payload_kg) {
  const double limit_kg = kMaxPayloadRatio * parameters_.mechanics.translator_mass_kg;
  if (!(payload_kg >= 0.0 && payload_kg <= limit_kg)) {
    throw ParameterError("payload_kg: " + std::to_string(payload_kg) + " kg is not in [0, " +
                         std::to_string(limit_kg) + "] kg (" + std::to_string(kMaxPayloadRatio) +
                         " times the translator's mass)");
  }
  payload_kg_ = payload_kg;
}

void SimulatedMotor::take_pending() noexcept {
  const Pending& due = pending_[static_cast<std::size_t>(pending_first_)];
  setpoints_ = due.setpoints;
  commanded_currents_ = due.currents;
  pending_first_ = (pending_first_ + 1) % kPendingCapacity;
  --pending_count_;
}

void SimulatedMotor::apply_due_setpoints(double time_s) noexcept {
  while (pending_count_ > 0 && pending_[static_cast<std::size_t>(pending_first_)].due_s <= time_s + 1e-12) {
    take_pending();
  }
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

void SimulatedMotor::take_setpoints(std::span<const DriveSetpoint> setpoints,
                                    std::span<const PhaseCurrentSetpoint> currents) noexcept {
  const double delay_s = parameters_.drive.setpoint_delay_s;
  if (delay_s == 0.0) {
    std::copy(setpoints.begin(), setpoints.end(), setpoints_.begin());
    std::copy(currents.begin(), currents.end(), commanded_currents_.begin());
    return;
  }
  if (pending_count_ == kPendingCapacity) take_pending();  // more in flight than it buffers: the oldest now
  Pending& next = pending_[static_cast<std::size_t>((pending_first_ + pending_count_) % kPendingCapacity)];
  next.due_s = time_s_ + delay_s;
  next.setpoints = setpoints_;
  next.currents = commanded_currents_;
  if (pending_count_ > 0) {  // on top of what is already in flight
    const Pending& last =
        pending_[static_cast<std::size_t>((pending_first_ + pending_count_ - 1) % kPendingCapacity)];
    next.setpoints = last.setpoints;
    next.currents = last.currents;
  }
  std::copy(setpoints.begin(), setpoints.end(), next.setpoints.begin());
  std::copy(currents.begin(), currents.end(), next.currents.begin());
  ++pending_count_;
}

void SimulatedMotor::take_command(bool enable) noexcept {
  if (enable && !enable_requested_) enabled_at_s_ = time_s_;
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
  take_setpoints(setpoints, {});
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
  take_setpoints({}, currents);
  take_command(enable);
  return result;
}

bool SimulatedMotor::drive_currents(double position_m, CurrentVector& currents_A) const noexcept {
  if (!drive_active()) {
    currents_A.setZero(2 * coil_sets());
    return false;
  }
  return phase_currents(position_m + encoder_offset_m_, setpoints_, commanded_currents_, currents_A);
}

double SimulatedMotor::counter_reading_m(double position_m) const noexcept {
  const double resolution_m = parameters_.sensors.encoder_resolution_m;
  const double reading_m = position_m + encoder_offset_m_;
  return resolution_m > 0.0 ? resolution_m * std::round(reading_m / resolution_m) : reading_m;
}

void SimulatedMotor::set_latch(bool armed, LatchSource source) noexcept {
  if (!armed || source != latch_source_) latch_caught_ = latch_fresh_ = false;
  latch_armed_ = armed;
  latch_source_ = source;
}

bool SimulatedMotor::take_latch(double& position_m) noexcept {
  if (!latch_fresh_) return false;
  latch_fresh_ = false;
  position_m = latch_position_m_;
  return true;
}

void SimulatedMotor::watch_latch(double from_m, double to_m) noexcept {
  if (!latch_armed_ || latch_caught_ || from_m == to_m) return;
  const auto& sensors = parameters_.sensors;
  double event_m = 0.0;
  if (latch_source_ == LatchSource::kIndex) {
    if (!(sensors.index_pitch_m > 0.0)) return;
    const double from_k = std::floor(from_m / sensors.index_pitch_m);
    const double to_k = std::floor(to_m / sensors.index_pitch_m);
    if (from_k == to_k) return;
    // The first mark passed: the boundary above `from` moving up, `from`'s own moving down.
    event_m = sensors.index_pitch_m * (to_m > from_m ? from_k + 1.0 : from_k);
  } else {
    if (!sensors.has_reference_switch()) return;
    const auto active = [&](double x) {
      return x >= sensors.reference_switch_min_m && x <= sensors.reference_switch_max_m;
    };
    if (active(from_m) || !active(to_m)) return;
    event_m = to_m > from_m ? sensors.reference_switch_min_m : sensors.reference_switch_max_m;
  }
  latch_position_m_ = counter_reading_m(event_m);
  latch_caught_ = latch_fresh_ = true;
}

bool SimulatedMotor::phase_currents(double position_m, std::span<const DriveSetpoint> setpoints,
                                    std::span<const PhaseCurrentSetpoint> currents,
                                    CurrentVector& currents_A) const noexcept {
  const int count = coil_sets();
  currents_A.setZero(2 * count);
  const bool phase_current = parameters_.drive.profile == DriveProfile::kPhaseCurrent;
  if (static_cast<int>(phase_current ? currents.size() : setpoints.size()) < count) return false;
  const double limit = parameters_.drive.phase_current_limit_A;
  bool limited = false;
  for (int l = 0; l < count; ++l) {
    const auto s = static_cast<std::size_t>(l);
    Eigen::Vector2d phase;
    if (phase_current) {
      // The commanded currents as they are (ideal current loop).
      phase << currents[s].ia_A, currents[s].ib_A;
    } else {
      // The drive's own fixed law, eq. (18)/(19), at the true position.
      phase = drive_phase_currents(parameters_.drive.commutation, setpoints[s], position_m, truth_.pole_pitch_m());
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

Wrench SimulatedMotor::ideal_drive_wrench(double position_m, std::span<const DriveSetpoint> setpoints,
                                          std::span<const PhaseCurrentSetpoint> currents) const noexcept {
  CurrentVector phase;
  phase_currents(position_m, setpoints, currents, phase);
  return truth_.wrench(position_m, 0.0, phase);
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
  const auto& mode = mechanics.flexible_mode;
  const double h = period_s / count;
  const double inverse_mass = 1.0 / motor_side_mass_kg();
  // The flexible mode: the encoder's side m₂ = f·m on a spring k and damper
  // c to the motor's m₁ = (1 − f)·m, so that the relative motion has the
  // mode's frequency and damping: k = ω²·μ, c = 2ζω·μ, μ = m₁·m₂/m.
  const double omega = kTwoPi * mode.frequency_Hz;
  const double encoder_mass_kg = mechanics.translator_mass_kg * mode.encoder_mass_fraction;
  const double reduced_mass_kg = (1.0 - mode.encoder_mass_fraction) * encoder_mass_kg;
  const double stiffness_N_per_m = omega * omega * reduced_mass_kg;
  const double damping_N_s_per_m = 2.0 * mode.damping_ratio * omega * reduced_mass_kg;
  const double deadline_s = parameters_.drive.watchdog_timeout_s - kWatchdogTolerance_s;
  const double start_s = time_s_;
  limited_in_last_step_ = false;
  step_mean_currents_A_.setZero(currents_A_.size());
  double position_sum_m = 0.0;

  for (int k = 0; k < count; ++k) {
    const double t = start_s + k * h;
    apply_due_setpoints(t);
    if (drive_active() && t - last_command_time_s_ >= deadline_s) latch_fault(kStatusWatchdog);
    if (drive_currents(position_m_, reference_A_)) {
      limited_in_last_step_ = true;
      ++current_limited_substeps_;
    }
    drive_windings(reference_A_, h);
    step_mean_currents_A_ += currents_A_;
    position_sum_m += position_m_;
    // The direction-dependent force's tanh and the friction's in one call:
    // two lanes of one vector cost what one does, with the bits of two calls.
    const double ratio[2] = {truth_.direction_ratio(velocity_m_per_s_),
                             velocity_m_per_s_ / mechanics.friction_smoothing_velocity_m_per_s};
    double shape[2];
    elementary::tanh_array(ratio, shape, 2);
    const double driving_force_N = truth_.driving_force_N(position_terms(position_m_), shape[0], currents_A_);
    // Semi-implicit (symplectic) Euler: velocities first, then the positions
    // with the new velocities.
    const double external_N = disturbance_force_N_ + disturbance_.force_N();
    if (mode.rigid()) {
      velocity_m_per_s_ +=
          h * inverse_mass * (driving_force_N + external_N - friction_N(velocity_m_per_s_, shape[1]));
      position_m_ += h * velocity_m_per_s_;
      encoder_position_m_ = position_m_;
      encoder_velocity_m_per_s_ = velocity_m_per_s_;
    } else {
      const double coupling_N = stiffness_N_per_m * (position_m_ - encoder_position_m_) +
                                damping_N_s_per_m * (velocity_m_per_s_ - encoder_velocity_m_per_s_);
      velocity_m_per_s_ +=
          h * inverse_mass * (driving_force_N + external_N - friction_N(velocity_m_per_s_, shape[1]) - coupling_N);
      encoder_velocity_m_per_s_ += h * coupling_N / encoder_mass_kg;
      position_m_ += h * velocity_m_per_s_;
      encoder_position_m_ += h * encoder_velocity_m_per_s_;
    }
    disturbance_.step(h);

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
        if (last_impact_speed_m_per_s_ > mechanics.end_stop_fault_speed_m_per_s) latch_fault(kStatusEndStop);
      }
      velocity_m_per_s_ = 0.0;
    }
    in_contact_ = position_m_ == mechanics.end_stop_max_m || position_m_ == mechanics.end_stop_min_m;
    if (mode.rigid()) encoder_position_m_ = position_m_;
    watch_latch(history_position_m_[static_cast<std::size_t>((history_next_ - 1 + kEncoderHistory) % kEncoderHistory)],
                encoder_position_m_);
    history_time_s_[static_cast<std::size_t>(history_next_)] = start_s + (k + 1) * h;
    history_position_m_[static_cast<std::size_t>(history_next_)] = encoder_position_m_;
    history_next_ = (history_next_ + 1) % kEncoderHistory;
    history_count_ = std::min(history_count_ + 1, kEncoderHistory);
  }
  time_s_ = start_s + period_s;
  step_mean_currents_A_ /= static_cast<double>(count);
  step_mean_position_m_ = position_sum_m / count;
  update_outputs();
  return StepResult::kOk;
}

void SimulatedMotor::update_outputs() noexcept {
  if (drive_active() &&
      time_s_ - last_command_time_s_ >= parameters_.drive.watchdog_timeout_s - kWatchdogTolerance_s) {
    latch_fault(kStatusWatchdog);
  }
  if (parameters_.drive.current_loop.ideal()) {
    drive_currents(position_m_, currents_A_);
  } else {
    // The windings keep their currents until the next substep; a drive that
    // stops (disable, fault) opens its bridge and they fall to zero.
    if (!drive_active()) current_loop_.reset(2 * coil_sets());
    currents_A_ = current_loop_.current_A();
  }
  wrench_ = truth_.wrench(position_terms(position_m_), velocity_m_per_s_, currents_A_);
}

void SimulatedMotor::drive_windings(const CurrentVector& reference_A, double h_s) noexcept {
  if (parameters_.drive.current_loop.ideal()) {
    currents_A_ = reference_A;
    return;
  }
  if (!drive_active()) {
    current_loop_.reset(2 * coil_sets());
  } else {
    // Back-EMF of phases a and b: the velocity times each phase's force
    // constant less the three phases' mean, which the floating star point
    // takes up (power F_y·v = Σ e·i over the three phases; SI units make
    // the constants equal).
    const auto& terms = position_terms(position_m_);
    CurrentVector emf_V(2 * coil_sets());
    for (int l = 0; l < coil_sets(); ++l) {
      const auto& sl = terms.s[static_cast<std::size_t>(l)];
      const double mean = (sl[0] + sl[1] + sl[2]) / 3.0;
      emf_V[2 * l] = velocity_m_per_s_ * (sl[0] - mean);
      emf_V[2 * l + 1] = velocity_m_per_s_ * (sl[1] - mean);
    }
    current_loop_.step(reference_A, emf_V, h_s);
  }
  currents_A_ = current_loop_.current_A();
}

double SimulatedMotor::encoder_side_position_m(double delay_s) const noexcept {
  // The newest history entry at or before now − delay, interpolated towards
  // the one after it; the oldest kept when the history does not reach back.
  const double wanted_s = time_s_ - delay_s;
  int newer = (history_next_ - 1 + kEncoderHistory) % kEncoderHistory;
  for (int n = 1; n < history_count_; ++n) {
    const int older = (newer - 1 + kEncoderHistory) % kEncoderHistory;
    const double t0 = history_time_s_[static_cast<std::size_t>(older)];
    if (t0 <= wanted_s) {
      const double t1 = history_time_s_[static_cast<std::size_t>(newer)];
      const double x0 = history_position_m_[static_cast<std::size_t>(older)];
      const double x1 = history_position_m_[static_cast<std::size_t>(newer)];
      return t1 > t0 ? x0 + (x1 - x0) * std::clamp((wanted_s - t0) / (t1 - t0), 0.0, 1.0) : x1;
    }
    newer = older;
  }
  return history_position_m_[static_cast<std::size_t>(newer)];
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
  double position = sensors.encoder_delay_s > 0.0 ? encoder_side_position_m(sensors.encoder_delay_s) : encoder_position_m_;
  if (sensors.encoder_interpolation_error_m > 0.0 || sensors.encoder_interpolation_second_m > 0.0) {
    const double angle = kTwoPi * position / sensors.encoder_scale_pitch_m;
    position += sensors.encoder_interpolation_error_m * elementary::sin(angle + interpolation_phase_rad_[0]) +
                sensors.encoder_interpolation_second_m * elementary::sin(2.0 * angle + interpolation_phase_rad_[1]);
  }
  position += sensors.encoder_noise_m * noise_.normal();
  frame.position_m = counter_reading_m(position);
  for (int q = 0; q < 3; ++q) {
    frame.wrench[q] = wrench_[q] + sensors.force_bias_N_N_Nm[q] + sensors.force_noise_N_N_Nm[q] * noise_.normal();
  }
  return frame;
}

DriveStatus SimulatedMotor::status() const noexcept {
  std::uint32_t word = latched_ & kLatchedBits;
  if (drive_active()) word |= kStatusEnabled;
  if (limited_in_last_step_) word |= kStatusCurrentLimited;
  const auto& mechanics = parameters_.mechanics;
  if (position_m_ <= mechanics.limit_switch_min_m || position_m_ >= mechanics.limit_switch_max_m) {
    word |= kStatusEndStop;
  }
  if (latch_caught_) word |= kStatusLatched;
  const auto& sensors = parameters_.sensors;
  if (sensors.has_reference_switch() && encoder_position_m_ >= sensors.reference_switch_min_m &&
      encoder_position_m_ <= sensors.reference_switch_max_m) {
    word |= kStatusReferenceSwitch;
  }
  return DriveStatus{word};
}

void SimulatedMotor::latch_internal_fault() noexcept {
  latch_fault(kStatusFault);
  update_outputs();
}

void SimulatedMotor::clear_fault() noexcept {
  latched_ = 0;
  pending_count_ = 0;
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
  state.encoder_side_position_m = encoder_position_m_;
  state.encoder_side_velocity_m_per_s = encoder_velocity_m_per_s_;
  state.disturbance_N = disturbance_.force_N();
  state.currents_A = currents_A_;
  state.wrench = wrench_;
  state.step_wrench = truth_.wrench(step_mean_position_m_, 0.0, step_mean_currents_A_);
  state.friction_N = friction_N(velocity_m_per_s_);
  state.end_stop_collisions = end_stop_collisions_;
  state.last_impact_speed_m_per_s = last_impact_speed_m_per_s_;
  state.current_limited_substeps = current_limited_substeps_;
  state.encoder_offset_m = encoder_offset_m_;
  return state;
}

}  // namespace clm::sim
