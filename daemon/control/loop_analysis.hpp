#pragma once
// The position loop's frequency response and stability margins for a plant
// beyond the rigid mass (docs/servod.md, "The position loop's margins"):
// the controller as implemented (the Tustin image
// of PidGains at the loop's period), a zero-order hold, the drive's current
// loop, pure delays, and one flexible mode between the motor's force and the
// encoder. Pure: no I/O, no allocation in the responses.

#include <complex>
#include <string>

#include "commutation/model_file.hpp"
#include "daemon/control/position_controller.hpp"

namespace clm::control {

/// What the loop drives: force at the motor's side to position at the
/// encoder. Every term beyond the mass may be absent (0).
struct PlantModel {
  double mass_kg = 0.0;                    ///< the whole translator, > 0
  double mode_frequency_Hz = 0.0;          ///< the flexible mode's undamped frequency; 0 = rigid
  double mode_damping_ratio = 0.02;        ///< its ζ, > 0
  double current_loop_bandwidth_Hz = 0.0;  ///< the force follows its demand as ω_c/(s + ω_c); 0 = at once
  double delay_s = 0.0;                    ///< pure delays in the loop: setpoint to force, encoder, computation [s]
};

/// P(jω) of `plant` at `frequency_Hz`: 1/(m s²) times the mode's
/// (2ζω_m s + ω_m²)/(s² + 2ζω_m s + ω_m²) (the encoder on the far side of a
/// spring and damper: the two-mass system's non-collocated response), times
/// the current loop and the delay [m/N].
std::complex<double> plant_response(const PlantModel& plant, double frequency_Hz);

/// The PID as PidController implements it: C((2/T)·(z − 1)/(z + 1)) at
/// z = e^(jωT) [N/m].
std::complex<double> controller_response(const PidGains& gains, double period_s, double frequency_Hz);

/// The open loop L = C(z)·H(jω)·P(jω), H the zero-order hold
/// (1 − e^(−jωT))/(jωT). Below the Nyquist frequency the sampled plant's
/// aliases are neglected (the plant falls as 1/ω²).
std::complex<double> loop_response(const PidGains& gains, double period_s, const PlantModel& plant,
                                   double frequency_Hz);

/// Margins of the loop, evaluated on a logarithmic grid from 0.1 Hz to the
/// Nyquist frequency (4000 points a decade, the phase unwrapped along it).
struct LoopMargins {
  double crossover_Hz = 0.0;        ///< the gain crossover (|L| = 1) with the smallest phase margin
  /// The smallest over every gain crossover of the rotation that would take
  /// L onto −1 there (0..180°). A resonance that lifts |L| above 1 adds two
  /// crossings; on the side of the plane away from −1 they cost no margin.
  /// The margins presume what the tuning rule gives on the rigid mass: a
  /// stable loop whose Nyquist plot the added terms deform.
  double phase_margin_deg = 0.0;
  /// The smallest −20·log10|L| over the phase crossovers above the first
  /// gain crossover (∞: none). Below it the integrator and the mass pass
  /// −180° with |L| ≫ 1: a bound on lowering the gain, not on raising it.
  double gain_margin_dB = 0.0;
  double gain_margin_Hz = 0.0;      ///< where it is (0: none)
  double peak_sensitivity = 0.0;    ///< max |1/(1 + L)| on the grid (the modulus margin's inverse)
  int gain_crossovers = 0;          ///< how many times |L| crosses 1 (a resonance can add crossings)
  /// The crossings of the negative real axis left of −1 (the phase passing
  /// an odd multiple of −180° where |L| > 1), +1 where the phase rises, −1
  /// where it falls. The PID's integral action on the mass starts L at
  /// −270°: a stable loop rises through −180° once with |L| ≫ 1 and crosses
  /// nowhere else left of −1 (Nyquist: the same count as the rigid loop the
  /// rule was made for, whose closed loop is stable). A mode below the
  /// crossover, or too much delay, adds a falling crossing: unstable, and the
  /// margins above do not apply.
  int real_axis_crossings = 0;
  bool stable() const { return real_axis_crossings == 1; }
};
/// Throws std::invalid_argument for a period or mass not positive and finite.
LoopMargins loop_margins(const PidGains& gains, double period_s, const PlantModel& plant);

/// The least margins a tuning of the position loop may leave: clm-servod
/// refuses a configuration, and a run-time `set`, whose loop keeps less on
/// the plant its motor file describes.
inline constexpr double kMinPhaseMargin_deg = 30.0;
inline constexpr double kMinGainMargin_dB = 6.0;

/// The plant a motor file describes (motor.flexible_mode, drive.current_loop,
/// drive.setpoint_delay_s and drive.position_delay_s, the two delays summed)
/// for a translator of `mass_kg`.
PlantModel described_plant(const MotorDescription& motor, double mass_kg);

/// Empty when the loop is stable on `plant` and keeps both least margins;
/// else what it is: "unstable (...)" or "short of the least margins (phase
/// margin 24.0 deg at 41 Hz, at least 30; gain margin 9.1 dB at 150 Hz, at
/// least 6)". Throws as loop_margins does.
std::string margin_shortfall(const PidGains& gains, double period_s, const PlantModel& plant);

}  // namespace clm::control
