// Homing (docs/servod.md, "Homing") on the shipped default motor, every
// plant term on, with an incremental encoder that powers up at a random
// offset: commutation finding against the simulator's truth, the index
// homing against the encoder's true offset, the bounds of both, and what is
// refused before homing.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include "commutation/transform.hpp"
#include "daemon/servod/axis_wiring.hpp"
#include "daemon_support.hpp"
#include "drivers/sim/motor_file.hpp"

using namespace clm;
using Kind = servo::CommandKind;
using servo::Fault;
using servo::HomingPhase;
using servo::ServoState;

namespace {

constexpr double kPi = 3.14159265358979323846;

struct PowerUp {
  std::uint64_t seed = 4;      ///< of the encoder's power-up offset
  double start_m = -0.05;      ///< the translator's true position at power-up
  double offset_max_m = 0.05;  ///< ± the offset's range: beyond one pole pitch (0.03 m)
};

/// The shipped motor with an incremental encoder: one index mark at true 0
/// in the stroke (a pitch of 1 m), the reference switch around it.
sim::MotorParameters incremental_motor(const PowerUp& power_up) {
  sim::MotorParameters motor = sim::load_motor_parameters(test::source_path("config/motor-sim.yaml"));
  motor.sensors.encoder_power_up_offset_max_m = power_up.offset_max_m;
  motor.sensors.encoder_offset_seed = power_up.seed;
  motor.sensors.index_pitch_m = 1.0;
  motor.sensors.reference_switch_min_m = 0.0;
  motor.sensors.reference_switch_max_m = 0.02;
  return motor;
}

servod::ServodConfig homing_config(control::HomingMethod method) {
  auto config = test::virtual_config();
  config.servo.homing.method = method;
  config.servo.homing.direction = 1;
  config.servo.homing.search_velocity_m_per_s = 0.005;
  config.servo.homing.search_distance_m = 0.2;
  config.servo.homing.reference_position_m = 0.0;  // the mark's (and the switch edge's) true position
  return config;
}

/// The daemon of `config` on `motor` (default: incremental_motor), the translator at power_up.start_m.
std::unique_ptr<servod::WiredAxis> wire(const servod::ServodConfig& config, const PowerUp& power_up,
                                        const sim::MotorParameters& motor) {
  auto wired = std::make_unique<servod::WiredAxis>(config, servod::wire_simulated_axis(config, motor));
  wired->simulated_motor()->reset(power_up.start_m);
  wired->daemon.run_cycles(10);
  return wired;
}
std::unique_ptr<servod::WiredAxis> wire(const servod::ServodConfig& config, const PowerUp& power_up) {
  return wire(config, power_up, incremental_motor(power_up));
}

/// The phase Δ that drives +y hardest through the drive's own law on its raw
/// reading at the translator's true position: the first harmonic of the
/// static F_y over Δ, from the simulator's truth (every coil set alike).
double true_phase_rad(const sim::SimulatedMotor& motor, double position_m) {
  const int sets = motor.coil_sets();
  constexpr int kSteps = 64;
  double a = 0.0, b = 0.0;
  for (int k = 0; k < kSteps; ++k) {
    const double delta = 2.0 * kPi * k / kSteps;
    std::vector<DriveSetpoint> setpoints(static_cast<std::size_t>(sets), DriveSetpoint{10.0, delta});
    const double force = motor.ideal_drive_wrench(position_m, setpoints, {}).x();
    a += force * std::cos(delta);
    b += force * std::sin(delta);
  }
  // ideal_drive_wrench commutates on the true position; the drive reads the
  // offset more, which its Δ must take back.
  const double offset_rad = 2.0 * kPi * motor.truth().encoder_offset_m / motor.parameters().pole_pitch_m();
  return wrap_angle_rad(std::atan2(b, a) - offset_rad);
}

/// Runs until homing is over (or a fault); the largest distance from `start_m` the translator reached.
double run_homing(servod::WiredAxis& wired, double start_m, std::int64_t max_cycles, double* finding_motion_m = nullptr) {
  double largest_m = 0.0;
  for (std::int64_t k = 0; k < max_cycles; ++k) {
    wired.daemon.run_cycles(1);
    const auto& status = wired.daemon.cycle().status();
    const double moved_m = std::abs(wired.simulated_motor()->truth().position_m - start_m);
    largest_m = std::max(largest_m, moved_m);
    if (finding_motion_m != nullptr && !status.commutation_found) *finding_motion_m = std::max(*finding_motion_m, moved_m);
    if (status.state == ServoState::kFault) break;
    if (status.homed && status.homing == HomingPhase::kIdle && !status.enabling) break;
  }
  return largest_m;
}

/// The daemon of `config` on `motor` at power_up, sent HOME and run until homing is over (or a fault).
std::unique_ptr<servod::WiredAxis> homed_from(const servod::ServodConfig& config, const PowerUp& power_up,
                                              const sim::MotorParameters& motor) {
  auto holder = wire(config, power_up, motor);
  REQUIRE(test::command(holder->daemon, Kind::kHome, 1).accepted());
  run_homing(*holder, power_up.start_m, 200000);
  return holder;
}

}  // namespace

TEST_CASE("home from power-up: commutation found within 0.02 rad of the truth, the index within 2 counts",
          "[daemon][homing]") {
  const auto config = homing_config(control::HomingMethod::kIndex);
  const double resolution_m = 1e-9;  // motor-sim.yaml's encoder_resolution_m
  // Offsets of both signs, four beyond one pole pitch (|offset| > 0.03 m: seeds 2, 9, 10, 22).
  for (const PowerUp power_up : {PowerUp{4, -0.05}, PowerUp{11, -0.09}, PowerUp{23, -0.02}, PowerUp{57, -0.07},
                                 PowerUp{9, -0.06}, PowerUp{10, -0.1}, PowerUp{22, -0.03}, PowerUp{2, -0.08}}) {
    auto holder = wire(config, power_up);
    auto& wired = *holder;
    sim::SimulatedMotor& motor = *wired.simulated_motor();
    const double offset_m = motor.truth().encoder_offset_m;
    INFO("seed " << power_up.seed << ", start " << power_up.start_m << " m, encoder offset " << offset_m << " m");
    REQUIRE(std::abs(offset_m) > 0.0);
    REQUIRE_FALSE(wired.daemon.cycle().status().homed);
    const double phase_truth = true_phase_rad(motor, power_up.start_m);

    REQUIRE(test::command(wired.daemon, Kind::kHome, 1).accepted());
    double finding_motion_m = 0.0;
    run_homing(wired, power_up.start_m, 200000, &finding_motion_m);
    const auto& status = wired.daemon.cycle().status();
    INFO("fault " << static_cast<int>(status.fault) << " (" << servo::describe(status.fault) << ")");
    REQUIRE(status.state == ServoState::kEnabled);
    REQUIRE(status.homed);
    const double phase_error = wrap_angle_rad(status.found_phase_rad - phase_truth);
    INFO("found phase " << status.found_phase_rad << " rad, truth " << phase_truth << " rad");
    CHECK(std::abs(phase_error) <= 0.02);
    INFO("finding moved " << finding_motion_m * 1e3 << " mm");
    CHECK(finding_motion_m <= config.servo.homing.finding.max_motion_m);
    // position = reading + axis_offset, reading = true + encoder offset: the
    // axis offset is the encoder's, negated, when the reference is the mark's true position.
    INFO("axis offset " << status.axis_offset_m << " m");
    CHECK(std::abs(status.axis_offset_m + offset_m) <= 2.0 * resolution_m);
    // And the loop holds where it stopped, in the new frame, without a step.
    wired.daemon.run_cycles(200);
    CHECK(wired.daemon.cycle().status().state == ServoState::kEnabled);
    CHECK(std::abs(wired.daemon.cycle().record().y_m - motor.truth().encoder_side_position_m) < 2e-8);
  }
}

TEST_CASE("before homing: moves to positions and position-dependent laws are refused, jog is allowed",
          "[daemon][homing]") {
  test::TemporaryDirectory dir;
  const auto files = test::write_truth_laws(dir, test::source_path("config/motor-sim.yaml"));
  const auto config = test::with_laws(homing_config(control::HomingMethod::kIndex), files, servo::CommutationMode::kOriginal);
  // Files made against an absolute encoder are in another frame than this axis's.
  CHECK_THROWS_WITH(wire(config, PowerUp{}), Catch::Contains("calibration.yaml") &&
                                                 Catch::Contains("encoder_reference: made against none") &&
                                                 Catch::Contains("this axis homes to index at 0 m"));
  // The calibration made against this axis's reference (index at 0 m) is taken.
  CalibrationFile calibration =
      test::truth_calibration(sim::load_motor_parameters(test::source_path("config/motor-sim.yaml")));
  calibration.reference = {"index", 0.0};
  test::write_text(files.calibration, format_calibration_file(calibration));
  auto referenced = config;
  referenced.commutation.pgnn_model_file.clear();
  referenced.commutation.spline_model_file.clear();
  auto holder = wire(referenced, PowerUp{});
  auto& daemon = holder->daemon;
  servo::Command classical;
  classical.kind = Kind::kSetCommutation;
  classical.commutation = servo::CommutationMode::kClassical;
  classical.sequence = 1;
  daemon.submit(classical);
  CHECK(test::cycle_answer(daemon, 1).result == servo::CommandResult::kRejectedNotHomed);
  // enable finds the commutation, then holds.
  REQUIRE(test::command(daemon, Kind::kEnable, 1).accepted());
  for (int k = 0; k < 20000 && !daemon.cycle().status().commutation_found; ++k) daemon.run_cycles(1);
  REQUIRE(daemon.cycle().status().commutation_found);
  REQUIRE(daemon.cycle().status().state == ServoState::kEnabled);
  CHECK_FALSE(daemon.cycle().status().homed);
  servo::Command move;
  move.kind = Kind::kMoveTo;
  move.target_m = daemon.cycle().record().y_m + 0.005;
  move.sequence = 2;
  daemon.submit(move);
  CHECK(test::cycle_answer(daemon, 2).result == servo::CommandResult::kRejectedNotHomed);
  servo::Command jog;
  jog.kind = Kind::kJog;
  jog.jog_velocity_m_per_s = 0.005;
  jog.limits = {0.005, 0.1, 10.0};
  jog.sequence = 3;
  daemon.submit(jog);
  CHECK(test::cycle_answer(daemon, 3).result == servo::CommandResult::kJogStarted);
  daemon.run_cycles(600);  // the jog times out and stops
  REQUIRE(daemon.run_until_idle(5000) < 5000);
  // Homed, the law is accepted.
  REQUIRE(test::command(daemon, Kind::kHome, 1).accepted());
  run_homing(*holder, holder->simulated_motor()->truth().position_m, 200000);
  REQUIRE(daemon.cycle().status().homed);
  classical.sequence = 4;
  daemon.submit(classical);
  CHECK(test::cycle_answer(daemon, 4).result == servo::CommandResult::kAccepted);
}

TEST_CASE("a configured law that needs the axis frame starts when homing completes, the drive's own law before",
          "[daemon][homing]") {
  test::TemporaryDirectory dir;
  const auto files = test::write_truth_laws(dir, test::source_path("config/motor-sim.yaml"));
  CalibrationFile calibration =
      test::truth_calibration(sim::load_motor_parameters(test::source_path("config/motor-sim.yaml")));
  calibration.reference = {"index", 0.0};
  test::write_text(files.calibration, format_calibration_file(calibration));
  auto config = test::with_laws(homing_config(control::HomingMethod::kIndex), files, servo::CommutationMode::kClassical);
  config.commutation.pgnn_model_file.clear();
  config.commutation.spline_model_file.clear();
  auto holder = wire(config, PowerUp{});
  auto& daemon = holder->daemon;
  CHECK(daemon.cycle().status().mode == servo::CommutationMode::kOriginal);
  REQUIRE(test::command(daemon, Kind::kHome, 1).accepted());
  bool classical_before_homed = false;
  for (std::int64_t k = 0; k < 200000; ++k) {
    daemon.run_cycles(1);
    const auto& status = daemon.cycle().status();
    classical_before_homed = classical_before_homed || (!status.homed && status.mode != servo::CommutationMode::kOriginal);
    if (status.state == ServoState::kFault || (status.homed && status.homing == HomingPhase::kIdle)) break;
  }
  const auto& status = daemon.cycle().status();
  INFO("fault " << static_cast<int>(status.fault));
  REQUIRE(status.homed);
  CHECK_FALSE(classical_before_homed);
  CHECK(status.mode == servo::CommutationMode::kClassical);
  // A law chosen before homing wins over the configured one.
  auto again = wire(config, PowerUp{});
  servo::Command original;
  original.kind = Kind::kSetCommutation;
  original.commutation = servo::CommutationMode::kOriginal;
  original.sequence = 1;
  again->daemon.submit(original);
  CHECK(test::cycle_answer(again->daemon, 1).accepted());
  REQUIRE(test::command(again->daemon, Kind::kHome, 1).accepted());
  run_homing(*again, again->simulated_motor()->truth().position_m, 200000);
  REQUIRE(again->daemon.cycle().status().homed);
  CHECK(again->daemon.cycle().status().mode == servo::CommutationMode::kOriginal);
}

TEST_CASE("homing that finds no reference within its distance latches 217 and stops", "[daemon][homing]") {
  auto config = homing_config(control::HomingMethod::kIndex);
  config.servo.homing.direction = -1;  // away from the only mark
  config.servo.homing.search_distance_m = 0.01;
  auto holder = wire(config, PowerUp{});
  auto& daemon = holder->daemon;
  REQUIRE(test::command(daemon, Kind::kHome, 1).accepted());
  const double start_m = holder->simulated_motor()->truth().position_m;
  const double largest_m = run_homing(*holder, start_m, 200000);
  CHECK(daemon.cycle().status().fault == Fault::kHomingNotFound);
  CHECK_FALSE(daemon.cycle().status().homed);
  // The quick stop rests within the search distance plus its braking.
  CHECK(largest_m < config.servo.homing.search_distance_m + 0.002);
  daemon.run_cycles(500);
  CHECK(holder->simulated_motor()->truth().end_stop_collisions == 0);
}

TEST_CASE("commutation finding on a translator that does not move latches 215", "[daemon][homing]") {
  auto config = homing_config(control::HomingMethod::kIndex);
  auto holder = wire(config, PowerUp{});
  auto& daemon = holder->daemon;
  // A clamped translator: an outside force far above what finding drives.
  holder->simulated_motor()->set_payload_kg(150.0);
  holder->simulated_motor()->set_disturbance_force_N(0.0);
  REQUIRE(test::command(daemon, Kind::kEnable, 1).accepted());
  for (int k = 0; k < 20000 && daemon.cycle().status().state == ServoState::kEnabled &&
                  !daemon.cycle().status().commutation_found;
       ++k) {
    daemon.run_cycles(1);
  }
  CHECK(daemon.cycle().status().fault == Fault::kCommutationNotFound);
  CHECK_FALSE(daemon.cycle().status().commutation_found);
}

TEST_CASE("commutation finding measures again when a push during the doublets made it inconsistent",
          "[daemon][homing]") {
  // A hand pushing the translator back and forth during the first
  // measurement only: that measurement is inconsistent; the next, undisturbed,
  // finds the phase. With one attempt the same push latches 215.
  constexpr int kPushCycles = 600, kFlipCycles = 17;
  constexpr double kPush_N = 20.0;
  const auto finding_cycles = [&](int attempts, Fault& fault, double& error_rad) {
    auto config = homing_config(control::HomingMethod::kIndex);
    config.servo.homing.finding.attempts = attempts;
    auto holder = wire(config, PowerUp{});
    auto& wired = *holder;
    const double truth = true_phase_rad(*wired.simulated_motor(), PowerUp{}.start_m);
    REQUIRE(test::command(wired.daemon, Kind::kEnable, 1).accepted());
    int k = 0;
    for (; k < 20000; ++k) {
      const bool pushing = k < kPushCycles;
      wired.simulated_motor()->set_disturbance_force_N(pushing ? ((k / kFlipCycles) % 2 ? kPush_N : -kPush_N) : 0.0);
      wired.daemon.run_cycles(1);
      const auto& status = wired.daemon.cycle().status();
      if (status.state != ServoState::kEnabled || status.commutation_found) break;
    }
    fault = wired.daemon.cycle().status().fault;
    error_rad = std::abs(wrap_angle_rad(wired.daemon.cycle().status().found_phase_rad - truth));
    return k;
  };
  Fault fault = Fault::kNone;
  double error_rad = 0.0;
  const int retried = finding_cycles(3, fault, error_rad);
  INFO("retried: " << retried << " cycles, fault " << static_cast<int>(fault) << ", phase error " << error_rad << " rad");
  CHECK(fault == Fault::kNone);
  CHECK(error_rad <= 0.02);
  Fault single_fault = Fault::kNone;
  double single_error_rad = 0.0;
  const int single = finding_cycles(1, single_fault, single_error_rad);
  INFO("one attempt: " << single << " cycles, fault " << static_cast<int>(single_fault));
  CHECK(single_fault == Fault::kCommutationNotFound);
  // The retried run took a second measurement: longer than the single one by about its length.
  CHECK(retried > single + single / 2);
}

TEST_CASE("homing to the reference switch's edge: the axis offset within 2 counts", "[daemon][homing]") {
  const auto config = homing_config(control::HomingMethod::kReferenceSwitch);
  for (const PowerUp power_up : {PowerUp{4, -0.05}, PowerUp{10, -0.1}}) {
    auto holder = homed_from(config, power_up, incremental_motor(power_up));
    const double offset_m = holder->simulated_motor()->truth().encoder_offset_m;
    INFO("seed " << power_up.seed << ", start " << power_up.start_m << " m, encoder offset " << offset_m << " m");
    const auto& status = holder->daemon.cycle().status();
    INFO("fault " << static_cast<int>(status.fault) << ", axis offset " << status.axis_offset_m << " m");
    REQUIRE(status.homed);
    // The switch's lower edge lies at true 0, the configured reference position.
    CHECK(std::abs(status.axis_offset_m + offset_m) <= 2e-9);
  }
}

TEST_CASE("an axis that starts inside the reference switch moves out of it first, then meets the edge from outside",
          "[daemon][homing]") {
  // The switch [0, 0.02] m, its lower edge searched upwards; the translator
  // starts at 0.01 m, inside it. Marks every 7 mm for index_in_switch.
  for (const bool index_in_switch : {false, true}) {
    auto config = homing_config(control::HomingMethod::kReferenceSwitch);
    config.servo.homing.index_in_switch = index_in_switch;
    config.servo.homing.reference_position_m = index_in_switch ? 0.007 : 0.0;
    const PowerUp power_up{9, 0.01};
    sim::MotorParameters motor = incremental_motor(power_up);
    motor.sensors.index_pitch_m = 0.007;
    auto holder = wire(config, power_up, motor);
    servod::WiredAxis& wired = *holder;
    const double offset_m = wired.simulated_motor()->truth().encoder_offset_m;
    INFO("index_in_switch " << index_in_switch << ", encoder offset " << offset_m << " m");
    REQUIRE(wired.simulated_motor()->status().reference_switch());
    REQUIRE(test::command(wired.daemon, Kind::kHome, 1).accepted());
    bool left = false;
    double lowest_m = power_up.start_m;
    for (std::int64_t k = 0; k < 200000; ++k) {
      wired.daemon.run_cycles(1);
      const auto& status = wired.daemon.cycle().status();
      left = left || status.homing == HomingPhase::kLeavingSwitch;
      lowest_m = std::min(lowest_m, wired.simulated_motor()->truth().position_m);
      if (status.state == ServoState::kFault || (status.homed && status.homing == HomingPhase::kIdle)) break;
    }
    const auto& status = wired.daemon.cycle().status();
    INFO("fault " << static_cast<int>(status.fault) << ", axis offset " << status.axis_offset_m << " m, lowest "
                  << lowest_m << " m");
    CHECK(left);
    REQUIRE(status.homed);
    CHECK(std::abs(status.axis_offset_m + offset_m) <= 2e-9);
    // Out through the lower edge (0) and back: below it, by no more than the stop's distance.
    CHECK(lowest_m < 0.0);
    CHECK(lowest_m > -0.005);
  }
}

TEST_CASE("a latch frame the search did not make, or a latch without its frame, latches 218 and the axis is not homed",
          "[daemon][homing]") {
  const auto config = homing_config(control::HomingMethod::kIndex);
  const PowerUp power_up{4, -0.05};
  auto holder = wire(config, power_up);
  auto& daemon = holder->daemon;
  auto& injection = holder->in_process_bus()->injection();
  SECTION("a frame naming a reading the search has not reached") {
    const double start_m = daemon.cycle().record().y_m;
    REQUIRE(test::command(daemon, Kind::kHome, 1).accepted());
    // Run until the search has moved 2 mm, then a frame 20 mm ahead of the axis.
    for (int k = 0; k < 200000 && daemon.cycle().record().y_m < start_m + 0.002; ++k) {
      daemon.run_cycles(1);
      REQUIRE(daemon.cycle().status().state != ServoState::kFault);
    }
    REQUIRE(daemon.cycle().status().homing == HomingPhase::kSearching);
    injection.spoof_latch = true;
    injection.spoof_latch_position_m = daemon.cycle().record().y_m + 0.02;
    CHECK(test::run_until_fault(daemon, 10) <= 2);
  }
  SECTION("the drive's latch frame lost") {
    injection.drop_latch_frames = 1;
    REQUIRE(test::command(daemon, Kind::kHome, 1).accepted());
    run_homing(*holder, power_up.start_m, 200000);
  }
  CHECK(daemon.cycle().status().fault == Fault::kLatchInvalid);
  CHECK_FALSE(daemon.cycle().status().homed);
  // The quick stop brings the axis to rest, short of the end stops.
  daemon.run_cycles(2000);
  CHECK(std::abs(holder->simulated_motor()->truth().velocity_m_per_s) < 1e-3);
  CHECK(holder->simulated_motor()->truth().end_stop_collisions == 0);
}

TEST_CASE("a move offered while an enable waits to find the commutation is refused", "[daemon][homing]") {
  auto holder = wire(homing_config(control::HomingMethod::kIndex), PowerUp{});
  auto& daemon = holder->daemon;
  REQUIRE(test::command(daemon, Kind::kEnable, 1).accepted());
  REQUIRE(daemon.cycle().status().enabling);
  REQUIRE_FALSE(daemon.cycle().status().commutation_found);
  servo::Command jog;
  jog.kind = Kind::kJog;
  jog.sequence = 2;
  jog.jog_velocity_m_per_s = 0.005;
  jog.limits = {0.005, 0.1, 10.0};
  daemon.submit(jog);
  CHECK(test::cycle_answer(daemon, 2).result == servo::CommandResult::kRejectedHoming);
}

TEST_CASE("homing to the index inside the reference switch: the switch says which mark, the mark where",
          "[daemon][homing]") {
  auto config = homing_config(control::HomingMethod::kReferenceSwitch);
  config.servo.homing.index_in_switch = true;
  // Marks every 7 mm: the switch [0, 0.02] m holds those at 0.007 and 0.014 m;
  // searching upwards from its lower edge, the first is at 0.007 m.
  config.servo.homing.reference_position_m = 0.007;
  for (const PowerUp power_up : {PowerUp{4, -0.05}, PowerUp{10, -0.1}}) {
    sim::MotorParameters motor = incremental_motor(power_up);
    motor.sensors.index_pitch_m = 0.007;
    auto holder = homed_from(config, power_up, motor);
    servod::WiredAxis& wired = *holder;
    const double offset_m = wired.simulated_motor()->truth().encoder_offset_m;
    INFO("seed " << power_up.seed << ", start " << power_up.start_m << " m, encoder offset " << offset_m << " m");
    const auto& status = wired.daemon.cycle().status();
    INFO("fault " << static_cast<int>(status.fault) << ", axis offset " << status.axis_offset_m << " m");
    REQUIRE(status.homed);
    CHECK(std::abs(status.axis_offset_m + offset_m) <= 2e-9);
    // It stopped past the mark at 0.007 m, not at the switch's edge.
    CHECK(wired.simulated_motor()->truth().position_m > 0.007);
  }
}

TEST_CASE("homing to the hard stop: the force limited, the stop found by the following error, backed off",
          "[daemon][homing]") {
  auto config = homing_config(control::HomingMethod::kHardStop);
  config.servo.homing.direction = -1;
  config.servo.homing.search_distance_m = 0.06;
  config.servo.homing.reference_position_m = -0.13;  // the lower hard stop's true position
  for (const PowerUp power_up : {PowerUp{4, -0.1}, PowerUp{10, -0.09}}) {
    sim::MotorParameters motor = incremental_motor(power_up);
    // No limit switches in the way; a contact slower than 2 cm/s is not a crash.
    motor.mechanics.limit_switch_min_m = -std::numeric_limits<double>::infinity();
    motor.mechanics.limit_switch_max_m = std::numeric_limits<double>::infinity();
    motor.mechanics.end_stop_fault_speed_m_per_s = 0.02;
    auto holder = homed_from(config, power_up, motor);
    servod::WiredAxis& wired = *holder;
    const double offset_m = wired.simulated_motor()->truth().encoder_offset_m;
    INFO("seed " << power_up.seed << ", start " << power_up.start_m << " m, encoder offset " << offset_m << " m");
    const auto& status = wired.daemon.cycle().status();
    const auto truth = wired.simulated_motor()->truth();
    INFO("fault " << static_cast<int>(status.fault) << ", axis offset " << status.axis_offset_m << " m, "
                  << truth.end_stop_collisions << " contact(s) at " << truth.last_impact_speed_m_per_s << " m/s");
    REQUIRE(status.homed);
    CHECK(truth.end_stop_collisions >= 1);  // it met the stop (and re-met it, pressed against it, at mm/s)
    CHECK(truth.last_impact_speed_m_per_s <= config.servo.homing.search_velocity_m_per_s * 1.5);
    // The reading at the stop: within what the mode's spring gives under the homing force and the
    // following error's threshold (2 µm and 0.2 mm here; measured below 10 µm).
    const double error_m = status.axis_offset_m + offset_m;
    INFO("offset error " << error_m * 1e6 << " um");
    CHECK(std::abs(error_m) < 1e-5);
    // Backed off by back_off_m (2 mm), then stopped within the stop limits.
    CHECK(truth.position_m > -0.13 + config.servo.homing.back_off_m);
    CHECK(truth.position_m < -0.13 + config.servo.homing.back_off_m + 0.001);
  }
}

TEST_CASE("commutation finding on a translator far lighter than sized for latches 216 near its bound",
          "[daemon][homing]") {
  const auto config = homing_config(control::HomingMethod::kIndex);
  const PowerUp power_up{};
  sim::MotorParameters motor = incremental_motor(power_up);
  // A tenth of control.mass_kg, on which the doublets are sized: each moves
  // the axis ten times as far (the friction's smoothing widened so that the
  // light translator still integrates stably).
  motor.mechanics.translator_mass_kg = 1.5;
  motor.mechanics.friction_smoothing_velocity_m_per_s = 0.01;
  motor.electromagnetics.direction_smoothing_velocity_m_per_s = 0.05;
  auto holder = wire(config, power_up, motor);
  auto& daemon = holder->daemon;
  REQUIRE(test::command(daemon, Kind::kEnable, 1).accepted());
  double largest_m = 0.0;
  for (int k = 0; k < 20000 && daemon.cycle().status().state == ServoState::kEnabled &&
                  !daemon.cycle().status().commutation_found;
       ++k) {
    daemon.run_cycles(1);
    largest_m = std::max(largest_m, std::abs(holder->simulated_motor()->truth().position_m - power_up.start_m));
  }
  CHECK(daemon.cycle().status().fault == Fault::kFindingMotion);
  CHECK_FALSE(daemon.cycle().status().commutation_found);
  // Zero setpoints from the cycle it was seen: the axis coasts to rest a little beyond the bound.
  daemon.run_cycles(500);
  INFO("largest excursion " << largest_m * 1e3 << " mm, at rest at "
                            << (holder->simulated_motor()->truth().position_m - power_up.start_m) * 1e3 << " mm");
  CHECK(std::abs(holder->simulated_motor()->truth().position_m - power_up.start_m) <
        2.0 * config.servo.homing.finding.max_motion_m);
}
