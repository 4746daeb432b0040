// clm commutate: desired wrenches to drive setpoints and currents, with the
// calibrated classical law (12) or a model's inverse (37) and (39).
#include <cstdio>
#include <memory>

#include "commutation/commutator.hpp"
#include "commutation/model_file.hpp"
#include "tools/cli/commands.hpp"
#include "tools/data/csv_table.hpp"
#include "tools/lcmlog/data_input.hpp"

namespace clm::cli {

void add_commutate(CLI::App& app) {
  auto* sub = app.add_subcommand("commutate", "commutate desired forces into drive setpoints and phase currents");
  struct Options {
    std::string motor, calibration, model, input, output, power = "true";
    data::DataLimits limits;
  };
  auto options = std::make_shared<Options>();
  sub->add_option("--motor", options->motor, "motor description (YAML)")->required()->check(lcmlog::existing_input_file());
  auto* calibration = sub->add_option("--calibration", options->calibration, "calibration file: classical law (12)")
                          ->check(lcmlog::existing_input_file());
  auto* model = sub->add_option("--model", options->model, "model file: inverse (37), then (39)")->check(lcmlog::existing_input_file());
  calibration->excludes(model);
  model->excludes(calibration);
  sub->add_option("--input", options->input, "desired forces (CSV with y_m, Fy_N, Fx_N, Tz_Nm)")->required()->check(lcmlog::existing_input_file());
  sub->add_option("--output", options->output, "setpoints to write (CSV)")->required();
  sub->add_option("--power", options->power, "minimum of ||i||^2 as printed (paper) or of ia^2+ib^2+ic^2 (true)")
      ->check(CLI::IsMember({"paper", "true"}))->capture_default_str();
  lcmlog::add_data_limit_options(*sub, options->limits, "--input");
  sub->callback([options] {
    if (options->calibration.empty() == options->model.empty()) {
      throw std::runtime_error("give exactly one of --calibration and --model");
    }
    const auto motor = load_motor_description(options->motor);
    std::unique_ptr<CommutationLaw> law;
    ModelFile model_file;  // outlives the law, which refers to its model
    std::vector<ClassicalEstimate> estimates;
    if (!options->calibration.empty()) {
      const auto calibration_file = load_calibration_file(options->calibration);
      check_matches_motor(calibration_file, motor, options->calibration, options->motor);
      estimates = calibration_file.estimates();
      law = std::make_unique<ClassicalCommutator>(estimates, motor.pole_pitch_m, motor.drive);
    } else {
      model_file = load_model_file(options->model);
      check_matches_motor(model_file.model, motor, options->model, options->motor);
      ModelCommutatorOptions commutator_options;
      commutator_options.power_metric = options->power == "true" ? PowerMetric::kTruePower : PowerMetric::kCurrentNorm;
      law = std::make_unique<ModelCommutator>(model_file.model, motor.drive, commutator_options);
    }
    const auto table = data::CsvTable::load(options->input, options->limits);
    const auto y = table.numbers("y_m");
    const auto fy = table.numbers("Fy_N");
    const auto fx = table.numbers("Fx_N");
    const auto tz = table.numbers("Tz_Nm");
    const int coil_sets = motor.coil_sets;
    std::vector<std::string> names = {"y_m"};
    for (int l = 1; l <= coil_sets; ++l) {
      for (const char* column : {"magnitude_N_", "delta_rad_", "ia_A_", "ib_A_"}) names.push_back(column + std::to_string(l));
    }
    std::vector<std::vector<double>> columns(names.size(), std::vector<double>(table.rows()));
    CommutationOutput out;
    std::size_t damped = 0;
    for (std::size_t r = 0; r < table.rows(); ++r) {
      law->commutate(y[r], {fy[r], fx[r], tz[r]}, out);
      damped += out.damping_engaged ? 1 : 0;
      columns[0][r] = y[r];
      for (int l = 0; l < coil_sets; ++l) {
        const auto base = static_cast<std::size_t>(1 + 4 * l);
        columns[base][r] = out.setpoints[static_cast<std::size_t>(l)].magnitude_N;
        columns[base + 1][r] = out.setpoints[static_cast<std::size_t>(l)].delta_rad;
        columns[base + 2][r] = out.currents_A[2 * l];
        columns[base + 3][r] = out.currents_A[2 * l + 1];
      }
    }
    data::write_csv_atomically(options->output, names, columns);
    std::printf("commutated %zu rows with %s; damped inverse engaged on %zu rows\nwrote %s\n", table.rows(),
                options->calibration.empty() ? "the model inverse (37)" : "calibrated classical commutation (12)",
                damped, options->output.c_str());
  });
}

}  // namespace clm::cli
