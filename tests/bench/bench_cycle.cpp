// Cost of one servo cycle for L = 3 coil sets: decode the drive and force
// frames, position loop with feedforward (40), commutation, encode the
// setpoint frames — the work of clm-servod between wake-up and sending,
// without the bus itself.
//
//   build/bin/bench_cycle --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>

#include "daemon/servo/servo_cycle.hpp"
#include "support/random_model.hpp"

namespace {

using namespace clm;

constexpr double kPolePitch = 0.03;
const DriveCommutation kDrive{67.0, -0.52};

servo::ServoSettings settings(int coil_sets, const CurrentLoopModel& current_loop = {}) {
  servo::ServoSettings s;
  s.current_loop = current_loop;
  s.period_s = 1e-3;
  s.pole_pitch_m = kPolePitch;
  s.drive = kDrive;
  s.protocol.coil_sets = coil_sets;
  s.pid = control::tune_pid(15.0, 40.0);
  s.feedforward = {15.0, 40.0, 15.0};
  s.soft_limit_min_m = -1.0;
  s.soft_limit_max_m = 1.0;
  s.following_error_limit_m = 1.0;  // the frames below do not follow the reference
  s.force_limit_N = 800.0;
  // A stroke wide enough for that following-error limit (the envelope wants
  // the soft limits inside it by twice the limit): the cycle's work is the same.
  s.machine.stroke_min_m = -10.0;
  s.machine.stroke_max_m = 10.0;
  return s;
}

// Feedback frames for 256 cycles with consecutive alive counters.
struct Feedback {
  std::array<drivers::ReceivedFrame, 256> drive{}, force{};
};

Feedback make_feedback(const can::ProtocolConfig& protocol) {
  Feedback f;
  std::mt19937_64 rng(5);
  // The axis holds around 0 with micrometre noise: the cost of a cycle does
  // not depend on where the axis is, and the loop stays out of its limits.
  std::uniform_real_distribution<double> force(-50.0, 50.0);
  for (int k = 0; k < 256; ++k) {
    const auto counter = static_cast<std::uint8_t>(k);
    // Zero mean over the ring, or the integrator would wind up over millions of cycles.
    const double y = 2e-6 * std::sin(2.0 * kPi * k / 256.0);
    can::encode_drive_feedback(protocol, {y, can::kStatusEnabled, counter}, f.drive[k].frame);
    can::encode_force_feedback(protocol, {Wrench(force(rng), 1.0, 0.1), counter}, f.force[k].frame);
    f.drive[k].timestamp_ns = f.force[k].timestamp_ns = 1LL << 62;  // never "late"
  }
  return f;
}

void run(benchmark::State& state, servo::CommutationMode mode, const CommutationLaw& law, int coil_sets,
         const CurrentLoopModel& current_loop = {}) {
  servo::ServoCycle cycle(settings(coil_sets, current_loop));
  cycle.install_law(servo::CommutationMode::kOriginal, &law);
  cycle.install_law(mode, &law);
  cycle.execute({.kind = servo::CommandKind::kSetCommutation, .commutation = mode});
  const Feedback feedback = make_feedback(cycle.settings().protocol);
  std::int64_t k = 0;
  const auto one = [&] {
    cycle.begin_cycle({});
    cycle.on_frame(feedback.drive[static_cast<std::size_t>(k & 255)]);
    cycle.on_frame(feedback.force[static_cast<std::size_t>(k & 255)]);
    const auto frames = cycle.end_cycle(0.0, {});
    benchmark::DoNotOptimize(frames.data());
    ++k;
  };
  one();
  cycle.execute({.kind = servo::CommandKind::kEnable});
  for (auto _ : state) one();
  if (cycle.status().state != servo::ServoState::kEnabled) {
    std::fprintf(stderr, "fault at cycle %ld of %ld: F %g y %g\n", static_cast<long>(cycle.status().fault_cycle),
                 static_cast<long>(k), cycle.record().F_star_N, cycle.record().y_m);
    state.SkipWithError(servo::describe(cycle.status().fault));
  }
}

struct Laws {
  std::vector<ClassicalEstimate> estimates;
  ElectromagneticModel pgnn, spline;
  std::unique_ptr<ClassicalCommutator> classical;
  std::unique_ptr<ModelCommutator> pgnn_law, spline_law;
  explicit Laws(int coil_sets) {
    std::mt19937_64 rng(coil_sets);
    for (int l = 0; l < coil_sets; ++l) estimates.push_back({61.0 + l, -0.54});
    pgnn = test::random_pgnn_model(coil_sets, kPolePitch, rng, {2}, {16});
    spline = test::random_spline_model(coil_sets, kPolePitch, rng);
    classical = std::make_unique<ClassicalCommutator>(estimates, kPolePitch, kDrive);
    pgnn_law = std::make_unique<ModelCommutator>(pgnn, kDrive);
    spline_law = std::make_unique<ModelCommutator>(spline, kDrive);
  }
};

void cycle_classical(benchmark::State& state) {
  const Laws laws(static_cast<int>(state.range(0)));
  run(state, servo::CommutationMode::kClassical, *laws.classical, static_cast<int>(state.range(0)));
}
void cycle_pgnn(benchmark::State& state) {
  const Laws laws(static_cast<int>(state.range(0)));
  run(state, servo::CommutationMode::kPgnn, *laws.pgnn_law, static_cast<int>(state.range(0)));
}
// The same with the drive's current loop compensated (drive.current_loop).
void cycle_pgnn_compensated(benchmark::State& state) {
  const Laws laws(static_cast<int>(state.range(0)));
  run(state, servo::CommutationMode::kPgnn, *laws.pgnn_law, static_cast<int>(state.range(0)), {1500.0, 2.0, 1e-3});
}
void cycle_spline(benchmark::State& state) {
  const Laws laws(static_cast<int>(state.range(0)));
  run(state, servo::CommutationMode::kSpline, *laws.spline_law, static_cast<int>(state.range(0)));
}

// The commutation call alone for L = 1..8 (the CAN protocol carries at most
// 4 coil sets, so the whole cycle is measured for L = 1..4).
void commutation_pgnn(benchmark::State& state) {
  const Laws laws(static_cast<int>(state.range(0)));
  CommutationOutput out;
  double y = -0.1;
  for (auto _ : state) {
    laws.pgnn_law->commutate(y, {100.0, 0.0, 0.0}, out);
    benchmark::DoNotOptimize(out.setpoints.data());
    y = y > 0.1 ? -0.1 : y + 1e-4;
  }
}

}  // namespace

BENCHMARK(cycle_classical)->Name("cycle/classical")->Arg(3);
BENCHMARK(cycle_pgnn)->Name("cycle/pgnn")->Arg(3);
BENCHMARK(cycle_spline)->Name("cycle/spline")->Arg(3);
BENCHMARK(cycle_pgnn_compensated)->Name("cycle/pgnn_current_loop")->Arg(3);
BENCHMARK(cycle_classical)->Name("cycle_scaling/classical")->DenseRange(1, 4);
BENCHMARK(cycle_pgnn)->Name("cycle_scaling/pgnn")->DenseRange(1, 4);
BENCHMARK(commutation_pgnn)->Name("commutation_scaling/pgnn")->DenseRange(1, 8);
BENCHMARK_MAIN();
