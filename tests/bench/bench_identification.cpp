// Identification of the default motor on its real commissioning experiments:
// 3 coil sets × 2 offsets × ~26 000 samples, generated at start-up by running
// the experiments on the daemon core (virtual clock), as `clm commission` does.
// Default options (PGNN: 5 restarts, 2 solver threads). Wall time, one
// identification per repetition; the CPU column counts every thread of the
// process. Figures: docs/benchmarks.md.
//
// Run: build/bin/bench_identification --benchmark_repetitions=3
//      (--benchmark_filter=identify/spline for the fast case alone)
#include <benchmark/benchmark.h>

#include <cstdio>
#include <string>

#include "support/daemon_experiments.hpp"
#include "tools/data/commissioning_steps.hpp"
#include "tools/data/csv_table.hpp"

namespace {

struct Experiments {
  clm::MotorDescription motor;
  clm::test::DaemonExperiments runs;
};

const Experiments& experiments() {
  static const Experiments data = [] {
    Experiments e;
    e.runs = clm::test::run_daemon_experiments(std::string(CLM_SOURCE_DIR) + "/config/servod.yaml");
    e.motor = e.runs.motor;
    return e;
  }();
  return data;
}

/// The tools' path: the experiment table, validated and grouped by read_experiment_data.
clm::data::ExperimentData experiment_data(std::size_t samples_per_run) {
  const auto columns = clm::test::experiment_columns(experiments().runs, samples_per_run);
  const auto table = clm::data::CsvTable::from_columns("experiments", columns.names, columns.values);
  return clm::data::read_experiment_data(table, experiments().motor);
}

void identify(benchmark::State& state, clm::ModelKind kind, std::size_t samples_per_run) {
  const clm::data::ExperimentData data = experiment_data(samples_per_run);
  clm::data::IdentifyOptions options;  // the defaults of clm identify and clm commission
  options.kind = kind;
  std::vector<clm::data::CoilSetIdentification> reports;
  for (auto _ : state) {
    auto model = clm::data::identify_motor(data, experiments().motor, options, reports);
    benchmark::DoNotOptimize(model);
  }
  std::size_t samples = 0;
  int iterations = 0;
  for (const auto& set : data.coil_sets) samples += static_cast<std::size_t>(set.dataset.position_m.size());
  for (const auto& report : reports) iterations += report.report.iterations;
  state.counters["samples"] = static_cast<double>(samples);
  state.counters["samples_per_group"] = static_cast<double>(samples) / (2.0 * static_cast<double>(data.coil_sets.size()));
  state.counters["lm_iterations"] = iterations;
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  const auto configure = [](benchmark::internal::Benchmark* b) {
    // Wall time is the figure; CPU is that of every thread of the process
    // (the solver's too), which the machine's other load does not inflate.
    b->UseRealTime()->MeasureProcessCPUTime()->Iterations(1)->Unit(benchmark::kSecond);
  };
  configure(benchmark::RegisterBenchmark("identify/pgnn", identify, clm::ModelKind::kPgnn, std::size_t{0}));
  configure(benchmark::RegisterBenchmark("identify/spline", identify, clm::ModelKind::kSpline, std::size_t{0}));
  for (std::size_t n : {6500, 13000, 26000}) {
    configure(benchmark::RegisterBenchmark(("identify/pgnn/samples:" + std::to_string(n)).c_str(), identify,
                                           clm::ModelKind::kPgnn, n));
  }
  std::fprintf(stderr, "running the commissioning experiments on the daemon core ...\n");
  const auto& data = experiments();
  std::size_t samples = 0;
  for (const auto& run : data.runs.runs) samples += run.samples.size();
  std::fprintf(stderr, "%zu runs, %zu samples\n", data.runs.runs.size(), samples);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
