// The closed-loop runner: what a record holds and how its samples belong
// together, experiment mode, and its argument checks.
#include <catch2/catch.hpp>
#include <cmath>
#include <stdexcept>

#include "commutation/classical.hpp"
#include "commutation/commutator.hpp"
#include "daemon/control/metrics.hpp"
#include "daemon/control/position_controller.hpp"
#include "daemon/control/trajectory.hpp"
#include "drivers/sim/oracle.hpp"
#include "drivers/sim/sim_support.hpp"
#include "tools/commission/closed_loop.hpp"

using namespace clm;
using namespace clm::sim;
using namespace clm::commission;

namespace {
constexpr double kPeriod = 1e-3;
}

TEST_CASE("every sample is one snapshot: the wrench and currents follow from its setpoints at its position",
          "[sim][loop]") {
  MotorParameters parameters = fixtures::default_motor();
  fixtures::ideal_sensors(parameters);
  SimulatedMotor motor(parameters);
  const DriveCommutation drive = parameters.drive.commutation;
  const std::vector<ClassicalEstimate> original(3, {drive.motor_constant_N_per_A, drive.phase_offset_rad});
  const ClassicalCommutator law(original, parameters.pole_pitch_m(), drive);
  const control::MoveProgram program = control::fig8_program_at(0.075);
  const auto gains = control::tune_pid(parameters.mechanics.translator_mass_kg, 40.0);
  const auto record = run_closed_loop(motor, program, control::PositionController(gains, {}, kPeriod),
                                      LoopCommutation::with_law(law), {0.2, true});
  REQUIRE(record.samples.size() ==
          static_cast<std::size_t>(std::ceil((program.duration_s() + 0.2) / kPeriod - 1e-9)));
  REQUIRE(record.first_fault_sample < 0);
  REQUIRE(record.coil_sets == 3);
  double max_tracking_error = 0.0;
  for (std::size_t k = 0; k < record.samples.size(); ++k) {
    const ClosedLoopSample& s = record.samples[k];
    REQUIRE(s.t_s == Approx((k + 1) * kPeriod).margin(1e-9));
    REQUIRE(s.r_m == program.sample((k + 1) * kPeriod).position_m);
    REQUIRE(s.y_m == s.true_position_m);  // ideal encoder
    REQUIRE(s.desired == Wrench(s.force_demand_N, 0.0, 0.0));
    REQUIRE(s.coil_set == 0);
    for (int l = 0; l < 3; ++l) {
      const Eigen::Vector2d expected =
          drive_phase_currents(drive, s.setpoints[static_cast<std::size_t>(l)], s.true_position_m, parameters.pole_pitch_m());
      REQUIRE((s.currents_A.segment<2>(2 * l) - expected).norm() < 1e-12);
    }
    const Wrench expected =
        motor.electromagnetics().wrench(s.true_position_m, s.true_velocity_m_per_s, s.currents_A);
    REQUIRE((s.measured - expected).norm() < 1e-12);
    REQUIRE(Wrench(s.Fy_N(), s.Fx_N(), s.Tz_Nm()) == s.measured);
    max_tracking_error = std::max(max_tracking_error, std::abs(s.r_m - s.y_m));
  }
  // 40 Hz feedback without feedforward keeps the translator within 0.5 mm.
  REQUIRE(max_tracking_error < 5e-4);
  REQUIRE(std::abs(record.samples.back().y_m - program.end_m()) < 5e-5);
}

TEST_CASE("experiment mode drives one coil set alone with magnitude F*_y and a constant offset", "[sim][loop]") {
  for (const bool two_coil : {false, true}) {
    MotorParameters parameters = two_coil ? fixtures::two_coil_motor() : fixtures::default_motor();
    SimulatedMotor motor(parameters);
    const int coil_sets = motor.coil_sets();
    const control::MoveProgram program = fixtures::stroke_program(parameters, 0.15);
    const auto gains = control::tune_pid(parameters.mechanics.translator_mass_kg, 30.0);
    for (int l = 0; l < coil_sets; ++l) {
      const double delta = l % 2 == 0 ? kPi / 4.0 : -kPi / 4.0;
      const auto record = run_closed_loop(motor, program, control::PositionController(gains, {}, kPeriod),
                                          LoopCommutation::experiment(l, delta));
      REQUIRE(record.first_fault_sample < 0);
      double sum_squares = 0.0;
      REQUIRE(record.magnitudes_N(l) == record.force_demands_N());
      for (const auto& s : record.samples) {
        REQUIRE(s.coil_set == l + 1);  // 1-based, as the CSV column
        for (int m = 0; m < coil_sets; ++m) {
          const auto& setpoint = s.setpoints[static_cast<std::size_t>(m)];
          if (m == l) {
            REQUIRE(setpoint.magnitude_N == s.force_demand_N);
            REQUIRE(s.magnitude_N(m) == s.force_demand_N);
            REQUIRE(s.delta_rad(m) == delta);
          } else {
            REQUIRE(setpoint.magnitude_N == 0.0);
            REQUIRE(s.ia_A(m) == 0.0);
            REQUIRE(s.ib_A(m) == 0.0);
          }
        }
        sum_squares += (s.r_m - s.y_m) * (s.r_m - s.y_m);
      }
      // The loop holds the reference with one coil set at Δ = ±π/4.
      REQUIRE(std::sqrt(sum_squares / record.samples.size()) < 1e-4);
    }
  }
}

TEST_CASE("the runner refuses a commutation that does not fit the motor", "[sim][loop]") {
  const MotorParameters parameters = fixtures::two_coil_motor();
  SimulatedMotor motor(parameters);
  const control::MoveProgram program = fixtures::stroke_program(parameters, 0.15);
  const control::PositionController controller(control::tune_pid(8.0, 30.0), {}, kPeriod);
  const std::vector<ClassicalEstimate> three(3, {50.0, 0.25});
  const ClassicalCommutator law(three, parameters.pole_pitch_m(), parameters.drive.commutation);
  REQUIRE_THROWS_WITH(run_closed_loop(motor, program, controller, LoopCommutation::with_law(law)),
                      Catch::Contains("3 coil sets, the motor 2"));
  REQUIRE_THROWS_WITH(run_closed_loop(motor, program, controller, LoopCommutation::experiment(2, 0.0)),
                      Catch::Contains("experiment coil set 2"));
  REQUIRE_THROWS(run_closed_loop(motor, program, controller, LoopCommutation::experiment(-1, 0.0)));
  const auto record = run_closed_loop(motor, program, controller, LoopCommutation::experiment(1, 0.0));
  REQUIRE_THROWS_AS(record.magnitudes_N(2), std::out_of_range);
}
