// Speed of the simulated motor (docs/simulator.md): 60 s of motor time at a 1 kHz
// control rate must take at most 1 s of CPU.
//   ./build/bin/bench_sim --benchmark_filter=SixtySeconds
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "commutation/classical.hpp"
#include "commutation/commutator.hpp"
#include "drivers/sim/motor.hpp"
#include "drivers/sim/motor_file.hpp"
#include "daemon/servod/program_file.hpp"
#include "tools/commission/runs.hpp"

namespace {

using namespace clm;
using namespace clm::sim;

constexpr double kPeriod_s = 1e-3;

MotorParameters default_motor() { return load_motor_parameters(std::string(CLM_SOURCE_DIR) + "/config/motor-sim.yaml"); }

// The plant alone: 60 000 periods of command → step → sense with the drive's
// own commutation carrying a ±20 N driving force at 2 Hz.
void BM_SixtySecondsAt1kHz(benchmark::State& state) {
  const MotorParameters parameters = default_motor();
  SimulatedMotor motor(parameters);
  const DriveCommutation drive = parameters.drive.commutation;
  const std::vector<ClassicalEstimate> estimates(3, {drive.motor_constant_N_per_A, drive.phase_offset_rad});
  const ClassicalCommutator law(estimates, parameters.pole_pitch_m(), drive);
  CommutationOutput out;
  const int periods = 60000;
  for (auto _ : state) {
    motor.reset(0.0);
    double checksum = 0.0;
    for (int k = 0; k < periods; ++k) {
      const SensorFrame frame = motor.sense();
      law.commutate(frame.position_m, Wrench(20.0 * std::cos(kTwoPi * 2.0 * k * kPeriod_s), 0.0, 0.0), out);
      motor.command(std::span<const DriveSetpoint>(out.setpoints.data(), 3), true);
      motor.step(kPeriod_s);
      checksum += frame.wrench.x();
    }
    benchmark::DoNotOptimize(checksum);
  }
  state.counters["motor_s_per_cpu_s"] =
      benchmark::Counter(60.0 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["substeps_per_period"] = motor.substeps(kPeriod_s);
}
BENCHMARK(BM_SixtySecondsAt1kHz)->Unit(benchmark::kMillisecond)->MinTime(3.0);

// One control period of the plant.
void BM_Period(benchmark::State& state) {
  SimulatedMotor motor(default_motor());
  motor.reset(0.0);
  const DriveSetpoint setpoints[3] = {{10.0, 0.0}, {10.0, 0.0}, {10.0, 0.0}};
  double sign = 1.0;
  for (auto _ : state) {
    sign = motor.truth().position_m > 0.05 ? -1.0 : motor.truth().position_m < -0.05 ? 1.0 : sign;
    const DriveSetpoint command[3] = {{sign * setpoints[0].magnitude_N, 0.0}, {sign * 10.0, 0.0}, {sign * 10.0, 0.0}};
    motor.command(command, true);
    motor.step(kPeriod_s);
    benchmark::DoNotOptimize(motor.sense());
  }
}
BENCHMARK(BM_Period)->Unit(benchmark::kMicrosecond);

// The whole Fig. 8 reference (≈ 26 s, with the approach and the settling
// before it) on the daemon's cycle with the original commutation, as the
// in-process commissioning runs every experiment and evaluation.
void BM_DaemonFig8(benchmark::State& state) {
  const std::string source_dir = CLM_SOURCE_DIR;
  const servod::ServodConfig config = servod::load_servod_config(source_dir + "/config/servod.yaml");
  commission::InProcessRunner runner(config);
  const servod::ProgramFile program = servod::load_program_file(source_dir + "/config/programs/fig8.yaml");
  runner.enable();
  std::int64_t cycles = 0;
  for (auto _ : state) {
    const commission::Recording run = runner.run_program(program, "", "fig8", commission::Disturbance::kRunsOn);
    cycles += static_cast<std::int64_t>(run.samples.size());
    benchmark::DoNotOptimize(run.samples.back().y_m);
  }
  state.counters["motor_s_per_cpu_s"] =
      benchmark::Counter(static_cast<double>(cycles) * config.servo.period_s, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DaemonFig8)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
