#pragma once
// Parameters of the simulated coreless linear motor: the true electromagnetics
// (eq. 7 plus the parasitics the classical model lacks), the mechanics, the
// drive with its fixed commutation and the sensors. docs/simulator.md explains
// every parameter physically; config/motor-sim.yaml is the default motor.
//
// Conventions: wrench triples are [F_y N, F_x N, T_z N·m] like clm::Wrench;
// positions are along the driving direction y; a "track position" is where on
// the magnet track a point of the translator is, u = y + offset.

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "commutation/types.hpp"

namespace clm::sim {

/// Thrown by validate() and the constructors for inconsistent parameters. The
/// message names the parameter and its value.
class ParameterError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// A smooth random function of track position u: a uniform cubic B-spline
/// with knot spacing `correlation_length_m` and independent normal
/// coefficients scaled so that its expected RMS is `rms`, plus a linear trend
/// `slope_per_m`·(u − centre of the travel). Its unit is that of the quantity it
/// varies (named where it is used).
struct SmoothVariation {
  double rms = 0.0;                    ///< expected RMS of the random part [unit]
  double correlation_length_m = 0.02;  ///< knot spacing [m], > 0
  double slope_per_m = 0.0;            ///< slow linear trend [unit/m]
};

/// The true parameters of one coil set in eq. (7)/(8).
struct CoilSetParameters {
  double motor_constant_N_per_A = 0.0;  ///< k^l [N/A], > 0
  double phase_offset_rad = 0.0;        ///< ζ^l [rad]
  /// d^l [m]: position of the coil set along y relative to the translator's
  /// centre of mass. It is the lever of F_x onto T_z (eq. 7) and says where on
  /// the magnet track the coil set is (track position y + d^l).
  double lever_arm_m = 0.0;
  /// e^l [m]: x offset of the line of action of the coil set's driving force;
  /// adds e^l·F_y^l to T_z.
  double driving_force_lever_arm_m = 0.0;
};

/// One harmonic of the periodic cogging force: amplitude per axis of
/// sin(2π·order·y/d_m + φ), φ drawn from the seed per axis.
struct CoggingHarmonic {
  int order = 1;                                     ///< multiple of the pole-pitch frequency, ≥ 1
  Wrench amplitude_N_N_Nm = Wrench::Zero();          ///< [N, N, N·m], ≥ 0
};

/// The true electromagnetic part Ψ: force = Σ_l K^l(y)·i^l + F_cog(y) + C·tanh(v/v_c).
struct ElectromagneticParameters {
  double pole_pitch_m = 0.0;        ///< d_m of eq. (8) [m], > 0
  double orthogonal_ratio = 0.0;    ///< μ of eq. (7) [-]
  std::vector<CoilSetParameters> coil_sets;  ///< L = 1..kMaxCoilSets entries

  /// Relative gain error of each phase winding, g_p = 1 + ε_p, ε_p ~ N(0, rms²)
  /// per coil set and phase [-].
  double phase_gain_mismatch_rms = 0.0;
  /// Relative magnet field intensity a(u): every coil set's gain is scaled by
  /// 1 + a(y + d^l) [-].
  SmoothVariation magnet_intensity;
  /// Magnet orientation β(u): shifts the electrical angle of eq. (8) by
  /// β(y + d^l) [rad].
  SmoothVariation magnet_orientation_rad;
  /// Relative amplitudes of the 5th and 7th field harmonics in every phase's
  /// force function sin(η_p) + h5·sin(5η_p + ψ5) + h7·sin(7η_p + ψ7) [-];
  /// ψ5, ψ7 drawn from the seed.
  double fifth_harmonic_relative = 0.0;
  double seventh_harmonic_relative = 0.0;

  /// Periodic cogging / cable force over the pole pitch.
  std::vector<CoggingHarmonic> cogging_periodic;
  /// Slow cogging / cable force over the stroke: one smooth random function
  /// per axis with these RMS values [N, N, N·m] and a common correlation length.
  Wrench cogging_slow_rms_N_N_Nm = Wrench::Zero();
  double cogging_slow_correlation_length_m = 0.05;  ///< [m], > 0
  /// Spring term of the cable slab: −rate·(y − neutral) per axis [N/m, N/m, N·m/m].
  Wrench cogging_spring_rate_N_N_Nm_per_m = Wrench::Zero();
  double cogging_spring_neutral_m = 0.0;  ///< [m]

  /// Direction-dependent force C·tanh(v/v_c) (paper Remark 5.1) [N, N, N·m]:
  /// seen by the force sensor, captured by no static model.
  Wrench direction_dependent_N_N_Nm = Wrench::Zero();
  double direction_smoothing_velocity_m_per_s = 1e-3;  ///< v_c [m/s], > 0

  /// Seed of every random draw of the truth (track functions, harmonic and
  /// cogging phases, phase gain errors).
  std::uint64_t seed = 1;

  int coil_set_count() const { return static_cast<int>(coil_sets.size()); }
  /// Throws ParameterError naming the first invalid field.
  void validate() const;
};

/// One flexible mode of the translator between the motor (where the coils'
/// force acts) and the encoder's read head: the translator's mass split in
/// two, coupled by a spring and a damper. frequency_Hz 0: rigid.
struct FlexibleModeParameters {
  double frequency_Hz = 0.0;           ///< undamped frequency of the mode [Hz], ≥ 0; 0 = rigid
  double damping_ratio = 0.02;         ///< ζ of the mode [-], in (0, 1]
  double encoder_mass_fraction = 0.3;  ///< share of translator_mass_kg on the encoder's side [-], in (0, 1)
  bool rigid() const { return frequency_Hz == 0.0; }
};

/// A band-limited force on the translator's motor side (floor vibration
/// through the base, the cable slab's stick-slip): a sum of kDisturbanceLines
/// sinusoids of equal amplitude at frequencies drawn uniformly in
/// [low_Hz, high_Hz] with random phases, whose RMS is rms_N. Not seen by the
/// force sensor (it measures the coils' wrench).
struct ForceDisturbanceParameters {
  double rms_N = 0.0;     ///< RMS of the force [N], ≥ 0; 0 = none
  double low_Hz = 1.0;    ///< lower band edge [Hz], > 0
  double high_Hz = 50.0;  ///< upper band edge [Hz], ≥ low_Hz
  std::uint64_t seed = 3; ///< seed of the frequencies and phases
};
inline constexpr int kDisturbanceLines = 64;

/// The translator moving along y on a bearing: rigid, or with one flexible mode.
struct MechanicsParameters {
  double translator_mass_kg = 0.0;                     ///< m [kg], > 0
  double viscous_friction_N_s_per_m = 0.0;             ///< b [N·s/m], ≥ 0
  double coulomb_friction_N = 0.0;                     ///< F_c [N], ≥ 0
  double friction_smoothing_velocity_m_per_s = 5e-4;   ///< v_s of F_c·tanh(v/v_s) [m/s], > 0
  /// Largest integration substep h [s], > 0: step(T) integrates with
  /// n = max(10, ⌈T/h⌉) equal substeps.
  double integration_step_s = 5e-5;
  double end_stop_min_m = -0.13;  ///< lower hard stop [m]
  double end_stop_max_m = 0.13;   ///< upper hard stop [m], > end_stop_min_m
  /// An impact on a hard stop faster than this latches kStatusEndStop and
  /// the drive's fault (a crash the machine's end-stop sensing reports);
  /// slower it is a contact the drive does not see, as a homing to the hard
  /// stop makes (docs/servod.md, "Homing") [m/s], ≥ 0; 0: every impact.
  double end_stop_fault_speed_m_per_s = 0.0;
  /// Limit switches: active while the translator is at or beyond them
  /// (DriveStatus kStatusEndStop), without faulting the drive; between the
  /// stroke and the hard stops [m]. Infinite: none (the stops' impact alone).
  double limit_switch_min_m = -std::numeric_limits<double>::infinity();  ///< −∞ or in [end_stop_min_m, limit_switch_max_m)
  double limit_switch_max_m = std::numeric_limits<double>::infinity();   ///< +∞ or in (limit_switch_min_m, end_stop_max_m]
  FlexibleModeParameters flexible_mode;
  ForceDisturbanceParameters force_disturbance;

  void validate() const;
};

/// The drive's current loop per phase: a PI controller tuned for
/// bandwidth_Hz by pole-zero cancellation (K_p = L·ω_c, K_i = R·ω_c, so that
/// the currents follow their setpoints as ω_c/(s + ω_c)), a bridge that
/// applies at most voltage_limit_V, and each phase winding's R and L with the
/// motor's back-EMF (its force constant times the velocity, SI units).
/// bandwidth_Hz 0: ideal, the currents equal their setpoints at once.
struct CurrentLoopParameters {
  double bandwidth_Hz = 0.0;          ///< closed-loop bandwidth [Hz], ≥ 0; 0 = ideal
  double phase_resistance_ohm = 2.0;  ///< R [Ω], > 0
  double phase_inductance_H = 1e-3;   ///< L [H], > 0
  double voltage_limit_V = 150.0;     ///< largest phase voltage [V], > 0
  bool ideal() const { return bandwidth_Hz == 0.0; }
};

/// The drive: a fixed classical commutation (eq. 18/19) or phase-current
/// setpoints (profile), current limit, setpoint watchdog.
struct DriveParameters {
  DriveCommutation commutation;        ///< k̂_d [N/A], ζ̂_d [rad]; used with profile magnitude_phase
  /// magnitude_phase: SimulatedMotor::command() takes (magnitude, Δ) and the
  /// drive commutates with its fixed law; phase_current: command_currents()
  /// takes [i_a, i_b] per coil set and the drive applies them as they are.
  DriveProfile profile = DriveProfile::kMagnitudePhase;
  double phase_current_limit_A = 10.0; ///< |i_a|, |i_b|, |i_c| ≤ limit [A], > 0
  double watchdog_timeout_s = 0.01;    ///< current stops this long after the last setpoint [s], > 0
  /// From an enable command to current applied and kStatusEnabled reported
  /// (power stage and current loop starting), at the first period boundary
  /// at or after it [s], 0..1.
  double enable_delay_s = 0.0;
  /// A setpoint takes effect this long after it is received (the drive's
  /// frame processing and PWM update) [s], 0..kMaxSetpointDelay_s. Enable
  /// and disable act at once.
  double setpoint_delay_s = 0.0;
  CurrentLoopParameters current_loop;

  void validate() const;
};

/// Encoder and force/torque sensor, sampled by sense().
struct SensorParameters {
  double encoder_resolution_m = 0.0;  ///< quantisation step [m], 0 = none, ≥ 0
  double encoder_noise_m = 0.0;       ///< standard deviation before quantisation [m], ≥ 0
  Wrench force_noise_N_N_Nm = Wrench::Zero();  ///< standard deviation per axis [N, N, N·m], ≥ 0
  Wrench force_bias_N_N_Nm = Wrench::Zero();   ///< constant offset per axis [N, N, N·m]
  std::uint64_t noise_seed = 2;                ///< seed of the measurement noise
  /// The encoder reports the position this long before sense() [s],
  /// 0..kMaxEncoderDelay_s (its sampling and the frame's way).
  double encoder_delay_s = 0.0;
  /// Interpolation error of the read head, periodic in the scale's pitch:
  /// a1·sin(2π·x/p + φ1) + a2·sin(4π·x/p + φ2), φ drawn from noise_seed.
  double encoder_scale_pitch_m = 20e-6;          ///< p [m], > 0
  double encoder_interpolation_error_m = 0.0;    ///< a1 [m], ≥ 0
  double encoder_interpolation_second_m = 0.0;   ///< a2 [m], ≥ 0
  /// An incremental encoder: its reading is the read head's true position
  /// plus an offset drawn once, at power-up (construction), uniformly in
  /// ±encoder_power_up_offset_max_m from encoder_offset_seed; 0: an
  /// absolute encoder, reading the true position [m], ≥ 0. The drive
  /// commutates on its reading, so an offset also shifts its commutation.
  double encoder_power_up_offset_max_m = 0.0;
  std::uint64_t encoder_offset_seed = 4;
  /// Index marks at every integer multiple of this on the scale (true
  /// position 0 is one); 0: none [m], ≥ 0.
  double index_pitch_m = 0.0;
  /// The reference switch: active while the read head's true position lies
  /// in [reference_switch_min_m, reference_switch_max_m]; absent when both
  /// are equal (the default) [m].
  double reference_switch_min_m = 0.0;
  double reference_switch_max_m = 0.0;
  bool has_reference_switch() const noexcept { return reference_switch_max_m > reference_switch_min_m; }

  void validate() const;
};

/// Most knots a smooth variation of the truth may have (ElectromagneticTruth
/// draws a B-spline with knots one correlation length apart over the track
/// the coil sets reach): 10^6, 8 MB per component. A correlation length
/// that tiny against the travel is refused, not allocated.
inline constexpr double kMaxTrackKnots = 1e6;

/// Longest setpoint delay and encoder delay the simulator keeps history for [s].
inline constexpr double kMaxSetpointDelay_s = 0.005;
inline constexpr double kMaxEncoderDelay_s = 0.002;

struct MotorParameters {
  double stroke_min_m = -0.1;  ///< lower end of the usable travel [m]
  double stroke_max_m = 0.1;   ///< upper end of the usable travel [m]
  ElectromagneticParameters electromagnetics;
  MechanicsParameters mechanics;
  DriveParameters drive;
  SensorParameters sensors;

  int coil_set_count() const { return electromagnetics.coil_set_count(); }
  double pole_pitch_m() const { return electromagnetics.pole_pitch_m; }
  /// Validates every part and their consistency (stroke inside the end stops,
  /// integration step small enough for the friction smoothing, at most
  /// kMaxTrackKnots knots for every smooth variation over the travel).
  void validate() const;
};

/// Sets every parasitic to zero (magnet track, harmonics, phase gain
/// mismatch, cogging, direction-dependent force, driving-force lever arms):
/// what is left is the classical motor of eq. (7). Mechanics, drive and
/// sensors are kept.
void switch_off_parasitics(ElectromagneticParameters& parameters);

/// The terms that inject an error into the loop, as a dynamic error budget
/// separates them from the plant's dynamics (docs/simulator.md, "A realistic
/// plant: sizes and what it does"): the force disturbance floor, and the
/// encoder's quantisation, noise, delay and interpolation error.
struct ErrorSources {
  bool force_disturbance = true;
  bool encoder = true;
};
/// `parameters` with only the sources in `kept`: a source left out is
/// switched off (no disturbance; an ideal encoder: no quantisation, noise,
/// delay or interpolation error); everything else, the dynamics included, as given.
MotorParameters with_error_sources(MotorParameters parameters, ErrorSources kept);

}  // namespace clm::sim
