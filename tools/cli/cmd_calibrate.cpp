// clm calibrate: Algorithm 1 per coil set from its two offset groups.
#include <cstdio>
#include <iostream>

#include "commutation/model_file.hpp"
#include "config/atomic_file.hpp"
#include "config/command_line.hpp"
#include "config/sha256.hpp"
#include "tools/cli/commands.hpp"
#include "tools/data/commissioning_steps.hpp"
#include "tools/data/position_model.hpp"
#include "tools/lcmlog/data_input.hpp"

namespace clm::cli {

void add_calibrate(CLI::App& app) {
  auto* sub = app.add_subcommand("calibrate", "Algorithm 1: calibrate k and zeta of every coil set from force data");
  struct Options {
    std::string motor, data, output;
    bool robust = false;
    double mass_kg = 0.0;
    double knot_spacing_m = 0.0;
    double viscous_N_s_per_m = 0.0;
    double direction_N = 0.0;
    EncoderReference reference;
    data::DataLimits limits;
    lcmlog::GapPolicy gaps;
  };
  auto options = std::make_shared<Options>();
  sub->add_option("--motor", options->motor, "motor description (YAML)")->required()->check(lcmlog::existing_input_file());
  sub->add_option("--data", options->data,
                  "experiment data: CSV, or an LCM log of clm-servod (docs/data-formats.md)")->required()->check(lcmlog::existing_input_file());
  sub->add_option("--output", options->output, "calibration file to write (YAML)")->required();
  sub->add_flag("--robust", options->robust,
                "write the offset-robust fit (a position-dependent offset fitted beside c_i) instead of the paper's");
  sub->add_option("--mass-kg", options->mass_kg,
                  "data without force columns: the translator's mass, which fixes the force scale (default: the "
                  "drive's nominal commutation does)")
      ->check(clm::non_negative_number())->capture_default_str();
  sub->add_option("--knot-spacing-m", options->knot_spacing_m,
                  "data without force columns: knot spacing of the model from positions (0: chosen by the held-out "
                  "force balance)")
      ->check(clm::non_negative_number())->capture_default_str();
  add_friction_options(*sub, options->viscous_N_s_per_m, options->direction_N);
  add_encoder_reference_options(*sub, options->reference);
  lcmlog::add_data_limit_options(*sub, options->limits, "--data");
  lcmlog::add_gap_option(*sub, options->gaps);
  sub->callback([options] {
    const auto motor = load_motor_description(options->motor);
    // The table (the file's text) is dropped once its rows are grouped.
    auto data = data::read_experiment_data(
        lcmlog::load_data_table(options->data, lcmlog::CsvFormat::kExperiment, options->limits, options->gaps), motor);
    data.reference = options->reference;
    if (!data.measured_forces) {
      // Algorithm 1 on the driving force a model identified from positions reconstructs.
      if (options->robust) {
        throw std::runtime_error("--robust: " + options->data + " has no force columns; the force reconstructed "
                                 "from positions has no offset to fit");
      }
      data::PositionIdentifyOptions position;
      position.motion.mass_kg = options->mass_kg;
      position.knot_spacing_m = options->knot_spacing_m;
      position.motion.viscous_N_s_per_m = options->viscous_N_s_per_m;
      position.motion.direction_N = options->direction_N;
      const auto identified = data::identify_from_position(data, motor, position);
      print_position_identification(identified);
      data::reconstruct_driving_force(data, motor, identified);
      CalibrationFile file = data::calibrate_motor(data, motor, data::CalibrationMethod::kPosition);
      file.data_sha256 = sha256_file(options->data);
      file.generator = generator_name("calibrate");
      write_file_atomically(options->output, format_calibration_file(file));
      std::printf("coil set  method     k [N/A]   zeta [rad]  c1       c2\n");
      for (std::size_t l = 0; l < file.coil_sets.size(); ++l) {
        const auto& c = file.coil_sets[l];
        std::printf("%-9zu %-10s %-9.4f %-11.4f %-8.5f %-8.5f\n", l + 1, file.method.c_str(),
                    c.estimate.motor_constant_N_per_A, c.estimate.phase_offset_rad, c.gain_ratio[0], c.gain_ratio[1]);
      }
      std::printf("wrote %s (position)\n", options->output.c_str());
      return;
    }
    const auto paper = data::calibrate_motor(data, motor, data::CalibrationMethod::kAlgorithm1);
    const auto robust = data::calibrate_motor(data, motor, data::CalibrationMethod::kOffsetRobust);
    CalibrationFile chosen = options->robust ? robust : paper;
    chosen.data_sha256 = sha256_file(options->data);
    chosen.generator = generator_name("calibrate");
    write_file_atomically(options->output, format_calibration_file(chosen));

    std::printf("coil set  method         k [N/A]   zeta [rad]  c1       c2       residual rms [N]\n");
    for (std::size_t l = 0; l < paper.coil_sets.size(); ++l) {
      for (const CalibrationFile* file : {&paper, &robust}) {
        const auto& c = file->coil_sets[l];
        std::printf("%-9zu %-14s %-9.4f %-11.4f %-8.5f %-8.5f %.3f / %.3f\n", l + 1, file->method.c_str(),
                    c.estimate.motor_constant_N_per_A, c.estimate.phase_offset_rad, c.gain_ratio[0], c.gain_ratio[1],
                    c.residual_rms_N[0], c.residual_rms_N[1]);
      }
    }
    // Fit quality: the ratios' standard errors, the conditioning of the
    // offsets' separation and the inflation by the fitted offset.
    std::printf("\ncoil set  method         se c1     se c2     separation  offset inflation\n");
    for (std::size_t l = 0; l < paper.coil_sets.size(); ++l) {
      for (const CalibrationFile* file : {&paper, &robust}) {
        const auto& c = file->coil_sets[l];
        const CalibrationQuality& q = *c.quality;
        std::printf("%-9zu %-14s %-9.2g %-9.2g %-11.2f %.2f / %.2f\n", l + 1, file->method.c_str(),
                    q.gain_ratio_standard_error[0], q.gain_ratio_standard_error[1], q.separation_condition,
                    q.offset_inflation[0], q.offset_inflation[1]);
        for (const auto& warning : calibration_warnings(c.gain_ratio.data(), q)) {
          std::fprintf(stderr, "clm calibrate: warning: coil set %zu (%s): %s\n", l + 1, file->method.c_str(),
                       warning.c_str());
        }
      }
    }
    std::printf("wrote %s (%s)\n", options->output.c_str(), chosen.method.c_str());
  });
}

}  // namespace clm::cli
