#pragma once
// Helpers for daemon tests: the default configuration on the virtual clock,
// commands, what went on the bus to the drive (seen on the in-process bus of
// the servod::WiredAxis that built the daemon), temporary files and
// commutation files made from the simulator's truth.

#include <catch2/catch.hpp>

#include <Eigen/Dense>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "commutation/classical.hpp"
#include "commutation/model_file.hpp"
#include "daemon/servod/axis_wiring.hpp"
#include "daemon/servod/servo_daemon.hpp"
#include "drivers/can/can_protocol.hpp"
#include "drivers/sim/in_process_bus.hpp"
#include "drivers/sim/motor.hpp"
#include "drivers/sim/motor_file.hpp"
#include "support/ideal_plant.hpp"
#include "support/temporary_directory.hpp"

namespace clm::test {

inline std::string source_path(const std::string& relative) { return std::string(CLM_SOURCE_DIR) + "/" + relative; }

/// The configuration at `path` with the virtual clock and no telemetry.
inline servod::ServodConfig virtual_config_at(const std::string& path) {
  auto config = servod::load_servod_config(path);
  config.loop.clock = servod::ClockMode::kVirtual;
  config.telemetry.enabled = false;
  return config;
}

/// config/servod.yaml (or `file`) with the virtual clock and no telemetry,
/// its encoder absolute (test::absolute_encoder_path).
inline servod::ServodConfig virtual_config(const std::string& file = "config/servod.yaml") {
  return virtual_config_at(absolute_encoder_path(file));
}

/// A program of config/programs/ as the ideal plant's copy of `file` holds
/// it: beside its configuration, where the daemon's file policy lets it be read.
inline std::string ideal_plant_program(const std::string& name, const std::string& file = "config/servod.yaml") {
  return ideal_plant_file("programs/" + name, file);
}

/// virtual_config on the ideal plant: for the tests of the cycle's own
/// mechanics, which a current loop, delays or a disturbance would blur.
inline servod::ServodConfig ideal_plant_config(const std::string& file = "config/servod.yaml") {
  return virtual_config_at(ideal_plant_path(file));
}

inline servod::CommandReply command(servod::ServoDaemon& daemon, servo::CommandKind kind,
                                    std::int64_t cycles = 1) {
  servo::Command c;
  c.kind = kind;
  auto reply = daemon.submit(c);
  daemon.run_cycles(cycles);
  return reply;
}

/// Runs one cycle and returns the one reply take_replies then gives for
/// `sequence`: a queued command's, or a move's once the cycle has taken its
/// program (or said why not). Take earlier replies first.
inline servod::CommandReply cycle_answer(servod::ServoDaemon& daemon, std::int64_t sequence = 0) {
  daemon.run_cycles(1);
  std::vector<servod::CommandReply> found;
  for (const auto& reply : daemon.take_replies()) {
    if (reply.sequence == sequence) found.push_back(reply);
  }
  REQUIRE(found.size() == 1);
  return found[0];
}

/// Submits SET_EXPERIMENT for `coil_set` at `delta_rad` (Algorithms 1 and
/// 2) and requires the daemon to take it into its queue.
inline void submit_experiment(servod::ServoDaemon& daemon, int coil_set, double delta_rad) {
  servo::Command experiment;
  experiment.kind = servo::CommandKind::kSetExperiment;
  experiment.coil_set = coil_set;
  experiment.delta_rad = delta_rad;
  REQUIRE(daemon.submit(experiment).accepted());
}

/// Submits SET_EXPERIMENT (coil set 1) and runs a cycle: the cycle must refuse
/// it because the axis has lost its force sensor.
inline void require_experiment_refused_for_the_sensor(servod::ServoDaemon& daemon) {
  servo::Command experiment;
  experiment.kind = servo::CommandKind::kSetExperiment;
  experiment.coil_set = 1;
  (void)daemon.take_replies();
  REQUIRE(daemon.submit(experiment).accepted());
  daemon.run_cycles(1);
  const auto replies = daemon.take_replies();
  REQUIRE(replies.size() == 1);
  CHECK_FALSE(replies[0].accepted());
  CHECK(replies[0].result == servo::CommandResult::kRejectedNoForceSensor);
}

inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  REQUIRE(out.good());
}

// ---------------------------------------------------------------------------
// What went on the bus

/// The setpoint frames the daemon transmitted in its last cycle, decoded with
/// the protocol's own decoder, as the drive would see them.
struct SentSetpoints {
  bool complete = false;  ///< every RPDO of the cycle was there and decoded
  std::size_t frames = 0;
  can::SetpointCommand command{};

  double magnitude_sum_N() const {
    double sum = 0.0;
    for (int l = 0; l < command.coil_sets; ++l) sum += command.setpoints[static_cast<std::size_t>(l)].magnitude_N;
    return sum;
  }
  /// Magnitudes zero and, for a phase-current drive, the currents too.
  bool all_magnitudes_zero() const {
    for (int l = 0; l < command.coil_sets; ++l) {
      const auto s = static_cast<std::size_t>(l);
      if (command.setpoints[s].magnitude_N != 0.0) return false;
      if (command.currents[s].ia_A != 0.0 || command.currents[s].ib_A != 0.0) return false;
    }
    return true;
  }
};

inline SentSetpoints sent_setpoints(servod::WiredAxis& axis) {
  const can::ProtocolConfig& protocol = axis.daemon.config().servo.protocol;
  SentSetpoints sent;
  unsigned mask = 0;
  for (const can::Frame& frame : axis.in_process_bus()->frames_since_sync()) {
    ++sent.frames;
    for (std::size_t index = 0; index < can::setpoint_frame_count(protocol.coil_sets); ++index) {
      if (frame.id != can::setpoint_id(protocol, index)) continue;
      REQUIRE(can::decode_setpoint_frame(protocol, frame, sent.command) == can::CodecStatus::kOk);
      mask |= 1u << index;
    }
  }
  sent.complete = mask == (1u << can::setpoint_frame_count(protocol.coil_sets)) - 1;
  return sent;
}

/// The last cycle put the axis in its safe state, checked where it matters:
/// every setpoint frame on the bus has zero magnitudes and enable cleared,
/// and (when the frames reached it) the simulated drive is disabled and
/// drives no current.
inline void require_safe_output(servod::WiredAxis& axis, bool frames_reached_drive = true) {
  const SentSetpoints sent = sent_setpoints(axis);
  REQUIRE(sent.complete);
  CHECK_FALSE(sent.command.enable);
  CHECK(sent.all_magnitudes_zero());
  if (frames_reached_drive) {
    const sim::SimulatedMotor& motor = *axis.simulated_motor();
    CHECK_FALSE(motor.status().enabled());
    CHECK(motor.truth().currents_A.cwiseAbs().maxCoeff() == 0.0);
  }
}

/// The axis is driven: once the enable handshake is over (the drive
/// reports Enabled, within faults.enable_timeout_s), the last cycle sent
/// enable and the drive is enabled.
inline void require_driving_output(servod::WiredAxis& axis) {
  const auto& settings = axis.daemon.config().servo;
  const auto handshake_cycles = std::llround(settings.enable_timeout_s / settings.period_s) + 2;
  for (long long k = 0; axis.daemon.cycle().status().enabling && k < handshake_cycles; ++k) axis.daemon.run_cycles(1);
  REQUIRE_FALSE(axis.daemon.cycle().status().enabling);
  const SentSetpoints sent = sent_setpoints(axis);
  REQUIRE(sent.complete);
  CHECK(sent.command.enable);
  CHECK(axis.simulated_motor()->status().enabled());
}

/// Runs single cycles until the cycle latches a fault; returns how many ran
/// (the fault is in the last), or max_cycles + 1 if none came.
inline std::int64_t run_until_fault(servod::ServoDaemon& daemon, std::int64_t max_cycles) {
  for (std::int64_t k = 1; k <= max_cycles; ++k) {
    daemon.run_cycles(1);
    if (daemon.cycle().status().state == servo::ServoState::kFault) return k;
  }
  return max_cycles + 1;
}

// ---------------------------------------------------------------------------
// Commutation files from the simulator's truth (for the modes that need a
// calibration or a model): close to what a perfect commissioning would give,
// made in milliseconds.

inline std::vector<ClassicalCoilSet> truth_classical(const sim::MotorParameters& motor) {
  std::vector<ClassicalCoilSet> sets;
  for (const auto& set : motor.electromagnetics.coil_sets) {
    sets.push_back({set.motor_constant_N_per_A, set.phase_offset_rad, motor.electromagnetics.orthogonal_ratio,
                    set.lever_arm_m});
  }
  return sets;
}

/// Algorithm 1's result if it hit the truth's k^l and ζ^l exactly.
inline CalibrationFile truth_calibration(const sim::MotorParameters& motor) {
  CalibrationFile file;
  file.pole_pitch_m = motor.pole_pitch_m();
  file.drive = motor.drive.commutation;
  file.method = "algorithm1";
  for (const auto& set : motor.electromagnetics.coil_sets) {
    file.coil_sets.push_back({{set.motor_constant_N_per_A, set.phase_offset_rad}, {-kPi / 4, kPi / 4}, {1.0, 1.0}, {0.0, 0.0}, {}});
  }
  file.data_sha256 = "truth";
  file.generator = "daemon tests";
  return file;
}

/// The classical model of the truth as a PGNN with zero networks of one
/// hidden layer (so the cycle evaluates the fused tanh layer). `gain_scale`
/// and `phase_shift_rad` perturb it to make a second, distinguishable model.
inline ModelFile truth_pgnn(const sim::MotorParameters& motor, double gain_scale = 1.0, double phase_shift_rad = 0.0) {
  auto sets = truth_classical(motor);
  for (auto& set : sets) {
    set.motor_constant_N_per_A *= gain_scale;
    set.phase_offset_rad += phase_shift_rad;
  }
  ModelFile file;
  file.model = make_classical_model(motor.pole_pitch_m(), sets, {8}, {8});
  // Physics-part harmonics of the orders identification offers, at zero: the
  // law stays the classical truth while the cycle evaluates every term.
  file.model.harmonics = {{5, 7}, {1, 2, 3, 4, 5, 6}};
  for (auto& part : file.model.coil_sets) {
    part.gain_harmonics_N_per_A = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, 8);
    part.cogging_harmonics_N = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, 12);
  }
  file.provenance = {"truth", "", "daemon tests", {}, {}};
  return file;
}

/// A spline model fitted by least squares to the static truth K^l(y) and
/// F_cog(y) on the whole travel (knots every 1.3 mm, 8 samples per interval).
inline ModelFile truth_spline(const sim::MotorParameters& parameters) {
  const sim::SimulatedMotor motor(parameters);
  const auto sets = truth_classical(parameters);
  ElectromagneticModel model;
  model.kind = ModelKind::kSpline;
  model.pole_pitch_m = parameters.pole_pitch_m();
  model.spline_basis = {parameters.mechanics.end_stop_min_m, parameters.mechanics.end_stop_max_m, 200};
  const int n = model.spline_basis.size();
  const int samples = 8 * model.spline_basis.intervals + 1;
  Eigen::MatrixXd basis = Eigen::MatrixXd::Zero(samples, n);
  std::vector<double> positions(static_cast<std::size_t>(samples));
  for (int j = 0; j < samples; ++j) {
    const double y = model.spline_basis.start_m +
                     (model.spline_basis.end_m - model.spline_basis.start_m) * j / (samples - 1);
    positions[static_cast<std::size_t>(j)] = y;
    const auto span = model.spline_basis.evaluate(y);
    for (int k = 0; k < 4; ++k) basis(j, span.first + k) = span.value[static_cast<std::size_t>(k)];
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(basis);
  const double angle_scale = 2.0 * kPi / model.pole_pitch_m;
  for (int l = 0; l < motor.coil_sets(); ++l) {
    CoilSetModel set;
    classical_physics_parameters(sets[static_cast<std::size_t>(l)], set.a_N_per_A, set.b_N_per_A);
    Eigen::MatrixXd column_a(samples, 3), column_b(samples, 3), cogging(samples, 3);
    for (int j = 0; j < samples; ++j) {
      const double y = positions[static_cast<std::size_t>(j)];
      const CoilGain physics = set.a_N_per_A * std::cos(angle_scale * y) + set.b_N_per_A * std::sin(angle_scale * y);
      const CoilGain residual = motor.true_gain(l, y) - physics;
      column_a.row(j) = residual.col(0).transpose();
      column_b.row(j) = residual.col(1).transpose();
      cogging.row(j) = motor.true_cogging(y).transpose();  // every set carries the whole: eq. (35) averages
    }
    set.column_a_spline = qr.solve(column_a).transpose();
    set.column_b_spline = qr.solve(column_b).transpose();
    set.cogging_spline = qr.solve(cogging).transpose();
    model.coil_sets.push_back(set);
  }
  ModelFile file;
  file.model = model;
  file.provenance = {"truth", "", "daemon tests", {}, {}};
  return file;
}

/// Paths of commutation files written for a motor.
struct LawFiles {
  std::string calibration, pgnn, spline;
};

inline LawFiles write_truth_laws(const TemporaryDirectory& dir, const std::string& motor_file) {
  const sim::MotorParameters motor = sim::load_motor_parameters(motor_file);
  LawFiles files{dir.file("calibration.yaml"), dir.file("pgnn.yaml"), dir.file("spline.yaml")};
  write_text(files.calibration, format_calibration_file(truth_calibration(motor)));
  write_text(files.pgnn, format_model_file(truth_pgnn(motor)));
  write_text(files.spline, format_model_file(truth_spline(motor)));
  return files;
}

/// `config` with every law available and `mode` selected.
inline servod::ServodConfig with_laws(servod::ServodConfig config, const LawFiles& files, servo::CommutationMode mode) {
  config.commutation.calibration_file = files.calibration;
  config.commutation.pgnn_model_file = files.pgnn;
  config.commutation.spline_model_file = files.spline;
  config.commutation.mode = mode;
  return config;
}

/// The default configuration (or `servod_file`) with every law available and `mode` selected.
inline servod::ServodConfig config_with_laws(const LawFiles& files, servo::CommutationMode mode,
                                             const std::string& servod_file = "config/servod.yaml") {
  return with_laws(virtual_config(servod_file), files, mode);
}

}  // namespace clm::test
