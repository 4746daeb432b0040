// libFuzzer harness: the experiment-data reader, tools/data/experiment_data.hpp
// read_experiment_data on CsvTable::parse, for the shipped three- and
// two-coil-set motors (config/motor-sim.yaml, config/motor-sim-2coil.yaml).
//
// Refusal: std::runtime_error (the header's promise). Invariants for accepted
// data: every coil set has two offsets more than 1e-9 rad apart, every row
// lands in exactly one group, and the dataset's group of a sample agrees with
// the per-group columns Algorithm 1 uses (same sizes, same positions in order);
// every row lands in exactly one motion run, whose columns agree in length;
// data without force columns carry no forces.

#include <array>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "fuzz_support.hpp"
#include "tools/data/experiment_data.hpp"

using clm::fuzz::require;

namespace {

void check(const clm::data::ExperimentData& data, const clm::data::CsvTable& table,
           const clm::MotorDescription& motor) {
  require(static_cast<int>(data.coil_sets.size()) == motor.coil_sets, "coil sets lost");
  std::size_t samples = 0, run_rows = 0;
  for (std::size_t l = 0; l < data.coil_sets.size(); ++l) {
    const auto& experiment = data.coil_sets[l];
    require(experiment.coil_set == static_cast<int>(l + 1), "coil sets out of order");
    require(std::abs(experiment.delta_rad[0] - experiment.delta_rad[1]) > 1e-9, "two offsets are one");
    const auto& set = experiment.dataset;
    require(set.currents_A.cols() == set.size() && set.wrench.cols() == (data.measured_forces ? set.size() : 0) &&
                static_cast<Eigen::Index>(set.group.size()) == set.size(),
            "dataset columns of different lengths");
    std::array<std::size_t, 2> next{0, 0};
    for (Eigen::Index k = 0; k < set.size(); ++k) {
      const int group = set.group[static_cast<std::size_t>(k)];
      require(group == 0 || group == 1, "group neither 0 nor 1");
      const auto g = static_cast<std::size_t>(group);
      require(next[g] < experiment.position_m[g].size(),
              "a sample's dataset group disagrees with the group it was read into", "coil set " + std::to_string(l + 1));
      require(experiment.position_m[g][next[g]] == set.position_m[k] ||
                  (std::isnan(experiment.position_m[g][next[g]]) && std::isnan(set.position_m[k])),
              "a sample's dataset group disagrees with the group it was read into", "coil set " + std::to_string(l + 1));
      ++next[g];
    }
    require(next[0] == experiment.position_m[0].size() && next[1] == experiment.position_m[1].size(),
            "group sizes disagree", "coil set " + std::to_string(l + 1));
    for (std::size_t g = 0; g < 2; ++g) {
      require(experiment.magnitude_N[g].size() == experiment.position_m[g].size() &&
                  experiment.driving_force_N[g].size() ==
                      (data.measured_forces ? experiment.position_m[g].size() : std::size_t{0}),
              "per-group columns of different lengths");
    }
    samples += static_cast<std::size_t>(set.size());
    for (const auto& run : experiment.runs) {
      require(run.position_m.size() > 0 && run.time_s.size() == run.position_m.size() &&
                  run.currents_A.cols() == run.position_m.size(),
              "a motion run's columns of different lengths", "coil set " + std::to_string(l + 1));
      run_rows += static_cast<std::size_t>(run.position_m.size());
    }
  }
  require(samples + data.unpaired_rows == table.rows(), "rows lost or duplicated");
  require(run_rows == table.rows(), "rows lost or duplicated in the motion runs");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const clm::MotorDescription motors[] = {
      clm::load_motor_description(clm::fuzz::source_path("config/motor-sim.yaml")),
      clm::load_motor_description(clm::fuzz::source_path("config/motor-sim-2coil.yaml")),
  };
  std::optional<clm::data::CsvTable> table;
  try {
    table.emplace(clm::data::CsvTable::parse(clm::fuzz::as_text(data, size), "fuzz.csv"));
  } catch (const std::runtime_error&) {
    return 0;
  }
  for (const auto& motor : motors) {
    try {
      check(clm::data::read_experiment_data(*table, motor), *table, motor);
    } catch (const std::runtime_error&) {
    }
  }
  return 0;
}
