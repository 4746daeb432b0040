// The default motor reproduces the situation of the paper's Table 2 (issue
// item 6): Algorithm 1 on experiment-mode Fig. 8 data, then the Fig. 8
// reference in closed loop with the original (uncalibrated) and the
// calibrated classical commutation.
#include <catch2/catch.hpp>
#include <array>
#include <cstdio>
#include <vector>

#include "commutation/calibration.hpp"
#include "commutation/commutator.hpp"
#include "daemon/control/metrics.hpp"
#include "daemon/control/position_controller.hpp"
#include "daemon/control/trajectory.hpp"
#include "sim/sim_support.hpp"
#include "tools/sim/closed_loop.hpp"
#include "tools/sim/oracle.hpp"

using namespace clm;
using namespace clm::sim;

namespace {

constexpr double kPeriod_s = 1e-3;
// Feedback bandwidth of the item-6 runs (docs/simulator.md).
constexpr double kBandwidth_Hz = 40.0;

struct CommutationFigures {
  control::DirectionMse mse;
  double tracking_mse_m2 = 0.0;
};

// Closed loop as in the paper's comparison: a first run without feedforward
// identifies m, f_v, f_c for this commutation (notes item 10), the second run
// with that feedforward is measured.
CommutationFigures measure(SimulatedMotor& motor, const control::MoveProgram& program, const CommutationLaw& law) {
  const auto gains = control::tune_pid(motor.parameters().mechanics.translator_mass_kg, kBandwidth_Hz);
  const auto identification = run_closed_loop(motor, program, control::PositionController(gains, {}, kPeriod_s),
                                              LoopCommutation::with_law(law));
  REQUIRE(identification.first_fault_sample < 0);
  const auto reference = identification.reference(program);
  const auto demands = identification.force_demands_N();
  const auto feedforward = control::identify_feedforward(reference, demands);
  const auto record = run_closed_loop(motor, program, control::PositionController(gains, feedforward, kPeriod_s),
                                      LoopCommutation::with_law(law));
  REQUIRE(record.first_fault_sample < 0);
  const auto measured = record.measured_wrenches();
  const auto desired = record.desired_wrenches();
  CommutationFigures figures;
  figures.mse = control::commutation_error_mse(measured, desired, kPeriod_s);
  figures.tracking_mse_m2 = control::mean_square(record.tracking_errors_m());
  return figures;
}

void print(const char* name, const CommutationFigures& f) {
  std::printf("%-10s MSE filtered (unfiltered): y %.2f (%.2f) N², x %.3f (%.3f) N², z %.3f (%.3f) N²m², tracking %.3g m²\n",
              name, f.mse.filtered[0], f.mse.unfiltered[0], f.mse.filtered[1], f.mse.unfiltered[1], f.mse.filtered[2],
              f.mse.unfiltered[2], f.tracking_mse_m2);
}

}  // namespace

TEST_CASE("default motor: calibrated classical commutation is worse than nothing static can fix, better than original",
          "[sim][paper]") {
  const MotorParameters parameters = test::default_motor();
  SimulatedMotor motor(parameters);
  const control::MoveProgram program = control::fig8_program();
  const DriveCommutation drive = parameters.drive.commutation;
  const int coil_sets = motor.coil_sets();
  const auto gains = control::tune_pid(parameters.mechanics.translator_mass_kg, kBandwidth_Hz);

  // Algorithm 1: each coil set alone, Δ = ∓π/4, closed loop without feedforward.
  std::vector<ClassicalEstimate> calibrated;
  for (int l = 0; l < coil_sets; ++l) {
    std::array<ClosedLoopRecord, 2> runs;
    std::array<std::vector<double>, 2> positions, magnitudes, forces;
    const double deltas[2] = {-kPi / 4.0, kPi / 4.0};
    for (int i = 0; i < 2; ++i) {
      runs[i] = run_closed_loop(motor, program, control::PositionController(gains, {}, kPeriod_s),
                                LoopCommutation::experiment(l, deltas[i]));
      REQUIRE(runs[i].first_fault_sample < 0);
      positions[i] = runs[i].measured_positions_m();
      magnitudes[i] = runs[i].magnitudes_N(l);
      forces[i] = runs[i].driving_forces_N();
    }
    const CalibrationResult result = calibrate_classical(
        drive.motor_constant_N_per_A, drive.phase_offset_rad, {deltas[0], positions[0], magnitudes[0], forces[0]},
        {deltas[1], positions[1], magnitudes[1], forces[1]});
    std::printf("coil set %d: true k %.2f N/A, zeta %.3f rad; Algorithm 1: k %.2f N/A, zeta %.3f rad\n", l + 1,
                parameters.electromagnetics.coil_sets[static_cast<std::size_t>(l)].motor_constant_N_per_A,
                parameters.electromagnetics.coil_sets[static_cast<std::size_t>(l)].phase_offset_rad,
                result.motor_constant_N_per_A, result.phase_offset_rad);
    calibrated.push_back({result.motor_constant_N_per_A, result.phase_offset_rad});
  }

  const std::vector<ClassicalEstimate> original(static_cast<std::size_t>(coil_sets),
                                                {drive.motor_constant_N_per_A, drive.phase_offset_rad});
  const ClassicalCommutator original_law(original, parameters.pole_pitch_m(), drive);
  const ClassicalCommutator classical_law(calibrated, parameters.pole_pitch_m(), drive);
  const OracleCommutator oracle_law(motor.electromagnetics(), drive);

  const CommutationFigures original_figures = measure(motor, program, original_law);
  const CommutationFigures classical_figures = measure(motor, program, classical_law);
  const CommutationFigures oracle_figures = measure(motor, program, oracle_law);
  print("original", original_figures);
  print("classical", classical_figures);
  print("oracle", oracle_figures);

  CHECK(classical_figures.mse.filtered[0] >= 15.0);
  CHECK(classical_figures.mse.filtered[0] <= 40.0);
  CHECK(original_figures.mse.filtered[0] > classical_figures.mse.filtered[0]);
}
