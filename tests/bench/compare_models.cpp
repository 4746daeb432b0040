// compare_models: evaluates PGNN model files side by side, for the benchmark
// "Identification against PyTorch" (docs/benchmarks.md,
// tools/reference/compare_identification.py). A plain executable, not a CTest
// test.
//
// For every model file (name=path):
//  * with --data: the cost (26) per coil set on the experiment data, on the
//    same training/validation split as identification (split_contiguous_blocks,
//    fraction 0.2), θ*_phy by fit_physics_only on the training data, Λ = 0.1·I:
//      cost = Σ_q mean_t (F_q − F̂_q)² + 0.1²·‖θ_phy − θ*_phy‖²
//    evaluated through ElectromagneticModel (coil_set_cost), i.e. by one code
//    path for every model whoever trained it;
//  * the closed-loop evaluation of `clm commission` (tools/commission/commission.cpp
//    step 4) on the daemon core with the embedded simulated motor on the
//    virtual clock: the model loaded into the pgnn law (servo::Command
//    kLoadModel), feedforward (40) identified from a run of the program
//    without feedforward, then the evaluation run with it; commutation MSE
//    (filtered and unfiltered, y/x/z) and tracking MSE, on the program
//    (Fig. 8) and on the held-out validation program. Every model gets a
//    fresh daemon built from the same configuration, so every model sees the
//    same simulator noise realisation (a paired comparison). The numbers
//    therefore differ slightly from report.json's, where the pgnn evaluation
//    runs after the other commutations on one daemon.
//  * with --time-ours: our identification (identify_motor, the function
//    `clm commission` and `clm identify` use, default options, or the paper's
//    with --no-nuisance --no-selection as in `clm commission`) timed in total
//    (the coil sets are identified side by side), without writing a file.
//
//   build/bin/compare_models --config config/servod.yaml --data DIR/experiments.csv
//       --model ours=DIR/model-pgnn.yaml --model torch=DIR/model-torch.yaml [--json out.json]
//       [--time-ours [--no-nuisance] [--no-selection]]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "commutation/identification/dataset.hpp"
#include "commutation/identification/physics_fit.hpp"
#include "commutation/identification/report.hpp"
#include "commutation/model_file.hpp"
#include "daemon/control/metrics.hpp"
#include "daemon/control/position_controller.hpp"
#include "tools/commission/commission.hpp"
#include "tools/commission/runs.hpp"
#include "tools/data/commissioning_steps.hpp"
#include "tools/data/csv_table.hpp"
#include "tools/data/experiment_data.hpp"

namespace {

using namespace clm;
using namespace clm::data;
using namespace clm::identification;
using Kind = servo::CommandKind;

struct NamedModel {
  std::string name;
  std::string path;
};

struct CoilSetCost {
  Eigen::Vector3d training = Eigen::Vector3d::Zero();
  Eigen::Vector3d validation = Eigen::Vector3d::Zero();
  double prior = 0.0;
  double cost26 = 0.0;
};

struct ClosedLoop {
  commission::CommutationResult program;
  std::optional<commission::CommutationResult> validation;
};

servo::Command make(Kind kind) {
  servo::Command command;
  command.kind = kind;
  return command;
}

using commission::evaluate;
using commission::identify_ff;

// The daemon configuration as `clm commission` prepares it.
servod::ServodConfig commissioning_config(const std::string& path) {
  servod::ServodConfig config = servod::load_servod_config(path);
  if (config.can.bus != servod::BusKind::kSimulated) throw std::runtime_error(path + ": can.interface must be sim");
  config.loop.clock = servod::ClockMode::kVirtual;
  config.telemetry.enabled = false;
  config.commutation.mode = servo::CommutationMode::kOriginal;
  config.servo.feedforward = {};
  return config;
}

ClosedLoop closed_loop(const servod::ServodConfig& config, const NamedModel& model, const servod::ProgramFile& program,
                       const std::optional<servod::ProgramFile>& validation_program) {
  servod::WiredAxis axis(config);
  servod::ServoDaemon& daemon = axis.daemon;
  daemon.run_cycles(20);
  commission::execute(daemon, make(Kind::kEnable));
  auto load = make(Kind::kLoadModel);
  load.commutation = servo::CommutationMode::kPgnn;
  load.path.assign(model.path);
  commission::execute(daemon, load);
  auto set = make(Kind::kSetCommutation);
  set.commutation = servo::CommutationMode::kPgnn;
  commission::execute(daemon, set);
  daemon.run_cycles(5);
  auto ff = make(Kind::kLoadFeedforward);  // no path: the parameters as given
  ff.feedforward = {};
  commission::execute(daemon, ff);
  const auto identification_run = commission::run_program(axis, program, model.name + " feedforward data", nullptr,
                                                            commission::Disturbance::kRestarts);
  ff.feedforward = identify_ff(identification_run);
  commission::execute(daemon, ff);
  ClosedLoop result;
  result.program = evaluate(commission::run_program(axis, program, model.name + " evaluation", nullptr,
                                                           commission::Disturbance::kRestarts), config.servo.period_s);
  result.program.name = model.name;
  result.program.feedforward = ff.feedforward;
  if (validation_program) {
    result.validation = evaluate(commission::run_program(axis, *validation_program, model.name + " validation", nullptr,
                                                         commission::Disturbance::kRestarts),
                                 config.servo.period_s);
    result.validation->name = model.name;
    result.validation->feedforward = ff.feedforward;
  }
  return result;
}

std::vector<CoilSetCost> costs_on_data(const ElectromagneticModel& model, const ExperimentData& data,
                                       double pole_pitch_m, const IdentifyOptions& options) {
  std::vector<CoilSetCost> costs;
  for (std::size_t l = 0; l < data.coil_sets.size(); ++l) {
    const auto& dataset = data.coil_sets[l].dataset;
    const auto split = split_contiguous_blocks(dataset, options.validation_fraction);
    const auto training = dataset.subset(split.training);
    const auto validation = dataset.subset(split.validation);
    const PhysicsFit physics = fit_physics_only(training, pole_pitch_m, 0.0);
    const CoilGain& a_star = physics.a_N_per_A;
    const CoilGain& b_star = physics.b_N_per_A;
    CoilSetCost c;
    c.training = coil_set_cost(model, static_cast<int>(l), training);
    c.validation = coil_set_cost(model, static_cast<int>(l), validation);
    const auto& part = model.coil_sets[l];
    const double lambda = options.pgnn.regularisation;
    c.prior = lambda * lambda * ((part.a_N_per_A - a_star).squaredNorm() + (part.b_N_per_A - b_star).squaredNorm());
    c.cost26 = c.training.sum() + c.prior;
    costs.push_back(c);
  }
  return costs;
}

std::string num(double v) {
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%.17g", v);
  return buffer;
}

std::string triple(const double* v) { return "[" + num(v[0]) + ", " + num(v[1]) + ", " + num(v[2]) + "]"; }

std::string result_json(const commission::CommutationResult& r) {
  return "{\"mse_filtered\": " + triple(r.mse.filtered.data()) + ", \"mse_unfiltered\": " +
         triple(r.mse.unfiltered.data()) + ", \"tracking_mse_m2\": " + num(r.tracking_mse_m2) +
         ", \"mean_current_square_A2\": " + num(r.mean_current_square_A2) + ", \"feedforward\": {\"mass_kg\": " +
         num(r.feedforward.mass_kg) + ", \"viscous_N_s_per_m\": " + num(r.feedforward.viscous_N_s_per_m) +
         ", \"coulomb_N\": " + num(r.feedforward.coulomb_N) + "}, \"damping_cycles\": " +
         std::to_string(r.damping_cycles) + ", \"force_limited_cycles\": " + std::to_string(r.force_limited_cycles) +
         "}";
}

void usage() {
  std::fprintf(stderr,
               "usage: compare_models --config servod.yaml --model NAME=model.yaml [--model NAME=model.yaml ...]\n"
               "                      [--data experiments.csv] [--program fig8.yaml] [--validation-program PATH|none]\n"
               "                      [--time-ours [--no-nuisance] [--no-selection]] [--no-closed-loop]\n"
               "                      [--json OUT.json]\n");
}

}  // namespace

int main(int argc, char** argv) {
  std::string config_path, data_path, program_path, validation_path, json_path;
  std::vector<NamedModel> models;
  bool time_ours = false, closed = true, nuisance = true, selection = true;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        usage();
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "--config") config_path = value();
    else if (arg == "--data") data_path = value();
    else if (arg == "--program") program_path = value();
    else if (arg == "--validation-program") validation_path = value();
    else if (arg == "--json") json_path = value();
    else if (arg == "--time-ours") time_ours = true;
    else if (arg == "--no-closed-loop") closed = false;
    else if (arg == "--no-nuisance") nuisance = false;
    else if (arg == "--no-selection") selection = false;
    else if (arg == "--model") {
      const std::string spec = value();
      const auto eq = spec.find('=');
      if (eq == std::string::npos || eq == 0) {
        usage();
        return 2;
      }
      models.push_back({spec.substr(0, eq), spec.substr(eq + 1)});
    } else {
      usage();
      return 2;
    }
  }
  if (config_path.empty() || (models.empty() && !time_ours)) {
    usage();
    return 2;
  }
  try {
    servod::ServodConfig config = commissioning_config(config_path);
    // The daemon loads files from its listed directories only, by absolute
    // path (commands.file_directories): each model's directory is added, as
    // `clm commission` adds its --out directory.
    for (auto& m : models) {
      m.path = std::filesystem::canonical(m.path).string();
      config.commands.file_directories.push_back(std::filesystem::path(m.path).parent_path().string());
    }
    const std::string config_dir = std::filesystem::path(config_path).parent_path().string();
    IdentifyOptions defaults;  // the options `clm commission` identifies with
    defaults.nuisance = nuisance;
    defaults.select_capacity = selection;
    std::ostringstream json;
    json << "{\n  \"config\": \"" << config_path << "\",\n  \"models\": {";

    std::optional<ExperimentData> data;
    if (!data_path.empty()) data = read_experiment_data(CsvTable::load(data_path), config.motor);

    for (std::size_t k = 0; k < models.size(); ++k) {
      const auto& m = models[k];
      const ModelFile file = load_model_file(m.path);
      check_matches_motor(file.model, config.motor, m.path, config.motor_file);
      json << (k ? "," : "") << "\n    \"" << m.name << "\": {\"path\": \"" << m.path << "\"";
      if (data) {
        const auto costs = costs_on_data(file.model, *data, config.motor.pole_pitch_m, defaults);
        std::printf("%s (%s): cost (26) per coil set on %s\n", m.name.c_str(), m.path.c_str(), data_path.c_str());
        std::printf("  coil set  cost(26)     prior        training y/x/z [N^2, N^2, N^2m^2]      validation y/x/z\n");
        json << ", \"coil_sets\": [";
        for (std::size_t l = 0; l < costs.size(); ++l) {
          const auto& c = costs[l];
          std::printf("  %-8zu  %-11.6g  %-11.4g  %9.4g %9.4g %9.4g        %9.4g %9.4g %9.4g\n", l + 1, c.cost26, c.prior,
                      c.training[0], c.training[1], c.training[2], c.validation[0], c.validation[1], c.validation[2]);
          json << (l ? ", " : "") << "{\"coil_set\": " << l + 1 << ", \"cost26\": " << num(c.cost26)
               << ", \"prior\": " << num(c.prior) << ", \"training_N2\": " << triple(c.training.data())
               << ", \"validation_N2\": " << triple(c.validation.data()) << "}";
        }
        json << "]";
      }
      if (closed) {
        const auto fit = [&](const std::string& path) {
          bool scaled = false;
          return servod::fit_program(servod::load_program_file(path), config.servo.soft_limit_min_m,
                                     config.servo.soft_limit_max_m, scaled);
        };
        const servod::ProgramFile program = fit(program_path.empty() ? config_dir + "/programs/fig8.yaml" : program_path);
        std::optional<servod::ProgramFile> validation;
        if (validation_path != "none") {
          validation = fit(validation_path.empty() ? config_dir + "/programs/validation.yaml" : validation_path);
        }
        const ClosedLoop r = closed_loop(config, m, program, validation);
        const auto print = [&](const char* what, const commission::CommutationResult& e) {
          std::printf("  %-10s commutation MSE filtered y %.4g N^2, x %.4g N^2, z %.4g N^2m^2 (unfiltered %.4g, %.4g, %.4g); "
                      "tracking MSE %.4g m^2\n",
                      what, e.mse.filtered[0], e.mse.filtered[1], e.mse.filtered[2], e.mse.unfiltered[0],
                      e.mse.unfiltered[1], e.mse.unfiltered[2], e.tracking_mse_m2);
        };
        std::printf("%s closed loop (fresh daemon, feedforward identified for this model):\n", m.name.c_str());
        print("program", r.program);
        json << ", \"program\": " << result_json(r.program);
        if (r.validation) {
          print("validation", *r.validation);
          json << ", \"validation\": " << result_json(*r.validation);
        }
      }
      json << "}";
      std::fflush(stdout);
    }
    json << "\n  }";

    if (time_ours) {
      if (!data) throw std::runtime_error("--time-ours needs --data");
      using Clock = std::chrono::steady_clock;
      // Process CPU time (all threads) beside wall time: the machine may be shared.
      const auto cpu_s = [] { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; };
      std::vector<CoilSetIdentification> reports;
      const auto start = Clock::now();
      const double start_cpu = cpu_s();
      // The coil sets are identified side by side: the total is what counts.
      identify_motor(*data, config.motor, defaults, reports, {});
      const double total_s = std::chrono::duration<double>(Clock::now() - start).count();
      const double total_cpu_s = cpu_s() - start_cpu;
      const std::string which = std::string(nuisance ? "nuisance terms" : "no nuisance terms") + ", " +
                                (selection ? "capacity chosen from the grid" : "the paper's 2/16 PGNN");
      std::printf("ours (identify_motor, %s): %.3f s wall, %.3f s CPU in total\n", which.c_str(), total_s,
                  total_cpu_s);
      json << ",\n  \"ours_timing\": {\"options\": \"" << which << "\", \"total_s\": " << num(total_s)
           << ", \"total_cpu_s\": " << num(total_cpu_s)
           << ", \"coil_sets\": [";
      for (std::size_t l = 0; l < reports.size(); ++l) {
        std::printf("  coil set %zu: cost (26) %.6g\n", l + 1, reports[l].report.regularised_cost);
        json << (l ? ", " : "") << "{\"coil_set\": " << l + 1
             << ", \"regularised_cost\": " << num(reports[l].report.regularised_cost) << "}";
      }
      json << "]}";
    }
    json << "\n}\n";
    if (!json_path.empty()) {  // atomically: a reader never sees half a report
      const std::string temporary = json_path + ".tmp";
      {
        std::ofstream out(temporary);
        out << json.str();
        out.flush();
        if (!out) throw std::runtime_error(temporary + ": cannot write");
      }
      std::filesystem::rename(temporary, json_path);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "compare_models: %s\n", e.what());
    return 1;
  }
  return 0;
}
