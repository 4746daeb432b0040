// One commutation call for L = 3 coil sets: phase currents and drive setpoints.
// Run: build/bin/bench_commutation --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "commutation/commutator.hpp"
#include "support/random_model.hpp"

namespace {

constexpr double kPolePitch = 0.032;
const clm::DriveCommutation kDrive{67.0, -0.52};

std::vector<double> positions() {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> position(-0.1, 0.1);
  std::vector<double> result(1024);
  for (auto& p : result) p = position(rng);
  return result;
}

void run(benchmark::State& state, const clm::CommutationLaw& law) {
  const auto ys = positions();
  clm::CommutationOutput out;
  std::size_t k = 0;
  for (auto _ : state) {
    law.commutate(ys[k++ & 1023], {150.0, 0.0, 0.0}, out);
    benchmark::DoNotOptimize(out.setpoints.data());
    benchmark::DoNotOptimize(out.currents_A.data());
  }
}

void classical(benchmark::State& state) {
  const clm::ClassicalEstimate estimates[3] = {{61.34, -0.54}, {61.62, -0.55}, {60.07, -0.55}};
  const clm::ClassicalCommutator law(estimates, kPolePitch, kDrive);
  run(state, law);
}

void pgnn(benchmark::State& state) {
  std::mt19937_64 rng(2);
  // The paper's sizes: 2 tanh neurons per column network, 16 in the cogging network.
  const auto model = clm::test::random_pgnn_model(3, kPolePitch, rng, {2}, {16});
  const clm::ModelCommutator law(model, kDrive);
  run(state, law);
}

void pgnn_harmonics(benchmark::State& state) {
  std::mt19937_64 rng(4);
  // The largest PGNN of the capacity grid: 16 neurons per column network, 32
  // in the cogging network, the field harmonics in the physics part.
  const auto model = clm::test::random_pgnn_model(3, kPolePitch, rng, {16}, {32}, {{5, 7}, {1, 2, 3, 4, 5, 6}});
  const clm::ModelCommutator law(model, kDrive);
  run(state, law);
}

void spline(benchmark::State& state) {
  std::mt19937_64 rng(3);
  const auto model = clm::test::random_spline_model(3, kPolePitch, rng);
  const clm::ModelCommutator law(model, kDrive);
  run(state, law);
}

}  // namespace

BENCHMARK(classical);
BENCHMARK(pgnn);
BENCHMARK(pgnn_harmonics);
BENCHMARK(spline);
BENCHMARK_MAIN();
