// clm identify: Algorithm 2 (PGNN) or the spline model for every coil set.
#include <cstdio>
#include <map>
#include <optional>
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
namespace {

// Data without force columns: the F_y rows from positions (docs/commutation.md, "Without a force sensor").
void identify_from_positions(const data::ExperimentData& data, const MotorDescription& motor,
                             data::PositionIdentifyOptions options, const std::string& data_path,
                             const std::string& output, const std::string& off_axis_path,
                             const std::string& motor_path) {
  // A force-sensor spline given: its knot grid, and its F_x and T_z rows.
  std::optional<ModelFile> off_axis;
  if (!off_axis_path.empty()) {
    off_axis = load_model_file(off_axis_path);
    check_matches_motor(off_axis->model, motor, off_axis_path, motor_path);
    if (off_axis->model.kind != ModelKind::kSpline || off_axis->provenance.rows_from[1] != RowSource::kForceSensor) {
      throw std::runtime_error("--off-axis-model " + off_axis_path +
                               ": a spline model whose F_x and T_z rows come from the force sensor is needed");
    }
    options.basis = off_axis->model.spline_basis;
  }
  data::PositionIdentification identified = data::identify_from_position(data, motor, options);
  ModelFile& file = identified.model;
  if (off_axis) data::take_off_axis_rows(file, *off_axis);
  file.provenance.data_sha256 = sha256_file(data_path);
  file.provenance.generator = generator_name("identify");
  write_file_atomically(output, format_model_file(file));
  print_position_identification(identified);
  std::printf("wrote %s\n", output.c_str());
}

}  // namespace

void print_position_identification(const data::PositionIdentification& identified) {
  const bool off_axis = identified.model.provenance.rows_from[1] == RowSource::kForceSensor;
  std::printf("spline model from positions (no force columns): F_y rows identified with the mechanics; F_x and T_z "
              "rows %s\n",
              off_axis ? "of the force-sensor model given" : "zero (the drive's constants)");
  std::printf("mass %.4g kg (%s)\n", identified.mass_kg,
              identified.mass_given       ? "given"
              : identified.friction_given ? "the one that makes the identified friction the friction given"
                                          : "scale from the drive's nominal commutation");
  for (const auto& [spacing, score] : identified.spacing_scores) {
    std::printf("knot spacing %.3g mm: held-out force balance RMS %.4g N%s\n", spacing * 1e3, score,
                spacing == identified.knot_spacing_m ? "  chosen" : "");
  }
  std::printf("coil set  rows     f_v [N s/m]  f_d [N]   balance RMS [N]  held-out RMS [N]\n");
  for (std::size_t l = 0; l < identified.fits.size(); ++l) {
    const auto& fit = identified.fits[l];
    std::printf("%-9zu %-8lld %-12.4g %-9.4g %-16.4g %.4g\n", l + 1, static_cast<long long>(fit.rows),
                fit.viscous_N_s_per_m, fit.direction_N, fit.residual_rms_N, identified.validation_residual_rms_N[l]);
  }
}

void add_friction_options(CLI::App& sub, double& viscous_N_s_per_m, double& direction_N) {
  sub.add_option("--viscous-N-s-per-m", viscous_N_s_per_m,
                 "data without force columns: the translator's viscous friction, known; it sets the force scale "
                 "instead of the mass")
      ->check(clm::non_negative_number());
  sub.add_option("--direction-force-N", direction_N,
                 "data without force columns: its Coulomb friction plus direction-dependent force, known; it sets "
                 "the force scale instead of the mass")
      ->check(clm::non_negative_number());
}

void add_encoder_reference_options(CLI::App& sub, EncoderReference& reference) {
  sub.add_option("--encoder-reference", reference.method,
                 "how the axis the data were recorded on was homed (its homing.method): none for an absolute "
                 "encoder; clm-servod takes the file only on an axis homed the same way")
      ->check(CLI::IsMember(std::vector<std::string>(kReferenceMethods.begin(), kReferenceMethods.end())))
      ->capture_default_str();
  sub.add_option("--reference-position-m", reference.position_m,
                 "the axis position homing gave the latched event (its homing.reference_position_m)")
      ->check(clm::in_range(-10.0, 10.0))
      ->capture_default_str();
}

void add_identify(CLI::App& app) {
  auto* sub = app.add_subcommand("identify", "Algorithm 2: identify a PGNN (or spline) model of the electromagnetics");
  struct Options {
    std::string motor, data, output, model = "pgnn";
    data::IdentifyOptions identify;
    double mass_kg = 0.0;
    double viscous_N_s_per_m = 0.0;
    double direction_N = 0.0;
    std::string off_axis_model;
    EncoderReference reference;
    data::DataLimits limits;
    lcmlog::GapPolicy gaps;
  };
  auto options = std::make_shared<Options>();
  auto& o = options->identify;
  sub->add_option("--motor", options->motor, "motor description (YAML)")->required()->check(lcmlog::existing_input_file());
  sub->add_option("--data", options->data, "experiment data: CSV, or an LCM log of clm-servod")->required()->check(lcmlog::existing_input_file());
  sub->add_option("--output", options->output, "model file to write (YAML)")->required();
  sub->add_option("--model", options->model, "model class")->check(CLI::IsMember({"pgnn", "spline"}))->capture_default_str();
  sub->add_option("--validation-fraction", o.validation_fraction, "held-out share, in contiguous blocks")
      ->check(clm::in_range(0.0, 0.9))->capture_default_str();
  sub->add_option("--column-neurons", o.pgnn.column_hidden, "tanh neurons per column network of K")
      ->check(clm::in_range(1, 64))->capture_default_str();
  sub->add_option("--cogging-neurons", o.pgnn.cogging_hidden, "tanh neurons of the cogging network")
      ->check(clm::in_range(1, 64))->capture_default_str();
  sub->add_flag_callback(
      "--harmonics", [&o] { o.pgnn.harmonics = clm::identification::field_harmonic_orders(); },
      "with --no-selection: the PGNN's physics part carries the field harmonics 5, 7 in K and the orders 1..6 in "
      "the cogging (the grid tries both)");
  sub->add_option("--regularisation", o.pgnn.regularisation, "Lambda = value * I in eq. (26)")
      ->check(clm::non_negative_number())->capture_default_str();
  sub->add_option("--restarts", o.pgnn.restarts, "seeded random restarts, best kept")->check(clm::in_range(1, 1000))->capture_default_str();
  sub->add_option("--seed", o.pgnn.seed, "seed of the restarts")->capture_default_str();
  sub->add_option("--restart-iterations", o.pgnn.restart_iterations, "LM iterations per restart")
      ->check(clm::in_range(1, 100000))->capture_default_str();
  sub->add_option("--final-iterations", o.pgnn.final_iterations, "LM iterations polishing the best restart")
      ->check(clm::in_range(0, 100000))->capture_default_str();
  sub->add_option("--restart-decimation", o.pgnn.restart_decimation, "restarts use every n-th training sample")
      ->check(clm::in_range(1, 1000))->capture_default_str();
  sub->add_option("--final-decimation", o.pgnn.final_decimation, "the polish uses every n-th training sample")
      ->check(clm::in_range(1, 1000))->capture_default_str();
  sub->add_option("--threads", o.pgnn.threads, "solver threads")->check(clm::in_range(1, 64))->capture_default_str();
  sub->add_option("--solver", o.pgnn.solver,
                  "PGNN training: variable-projection (Levenberg-Marquardt on the hidden layers, eq. (31) at every "
                  "step) or joint (the paper's: Levenberg-Marquardt on all parameters, Ceres; not reproducible "
                  "across CPUs)")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, identification::PgnnSolver>{
              {"variable-projection", identification::PgnnSolver::kVariableProjection},
              {"joint", identification::PgnnSolver::kJointSchur}}))
      ->default_str("variable-projection");
  sub->add_option("--knot-spacing-m", o.spline.knot_spacing_m, "spline knot spacing (0: pole pitch / 8)")
      ->check(clm::non_negative_number())->capture_default_str();
  sub->add_option("--smoothing", o.spline.smoothing, "spline roughness penalty")->check(clm::non_negative_number())->capture_default_str();
  sub->add_option("--mass-kg", options->mass_kg,
                  "data without force columns: the translator's mass, which fixes the force scale (default: the "
                  "drive's nominal commutation does)")
      ->check(clm::non_negative_number())->capture_default_str();
  add_encoder_reference_options(*sub, options->reference);
  add_friction_options(*sub, options->viscous_N_s_per_m, options->direction_N);
  sub->add_option("--off-axis-model", options->off_axis_model,
                  "data without force columns: a spline model of a force-sensor identification whose F_x and T_z rows "
                  "(and knot grid) the model takes (default: zero rows, the drive's constants)")
      ->check(lcmlog::existing_input_file());
  sub->add_flag("!--no-nuisance", o.nuisance,
                "fit the model alone, as the paper does (default: the sensor's F_y offset and the direction-dependent "
                "force are identified beside it)");
  sub->add_flag("!--no-selection", o.select_capacity,
                "use --column-neurons/--cogging-neurons/--regularisation or --knot-spacing-m as given (default: "
                "chosen from a grid by validation error)");
  lcmlog::add_data_limit_options(*sub, options->limits, "--data");
  lcmlog::add_gap_option(*sub, options->gaps);
  sub->callback([options, sub] {
    options->identify.kind = options->model == "pgnn" ? ModelKind::kPgnn : ModelKind::kSpline;
    options->identify.spline.regularisation = options->identify.pgnn.regularisation;
    const auto motor = load_motor_description(options->motor);
    // The table (the file's text) is dropped once its rows are grouped, before
    // the identification's own matrices are made (docs/benchmarks.md, memory).
    auto data = data::read_experiment_data(
        lcmlog::load_data_table(options->data, lcmlog::CsvFormat::kExperiment, options->limits, options->gaps), motor);
    data.reference = options->reference;
    if (data.measured_forces && !options->off_axis_model.empty()) {
      throw std::runtime_error("--off-axis-model: " + options->data +
                               " has force columns; a model of F_x and T_z is for data without them");
    }
    if (!data.measured_forces) {
      if (sub->count("--model") > 0 && options->model != "spline") {
        throw std::runtime_error("--model " + options->model + ": " + options->data +
                                 " has no force columns; from positions only the spline class is identified");
      }
      data::PositionIdentifyOptions position;
      position.motion.mass_kg = options->mass_kg;
      position.motion.viscous_N_s_per_m = options->viscous_N_s_per_m;
      position.motion.direction_N = options->direction_N;
      // As the force-sensor spline: chosen from the grid, or as given (pole pitch / 8 by default).
      const double given_m = options->identify.spline.knot_spacing_m;
      position.knot_spacing_m = options->identify.select_capacity ? 0.0
                                : given_m > 0.0                    ? given_m
                                                                   : motor.pole_pitch_m / 8.0;
      position.motion.smoothing = options->identify.spline.smoothing;
      position.validation_fraction = options->identify.validation_fraction;
      identify_from_positions(data, motor, position, options->data, options->output, options->off_axis_model,
                              options->motor);
      return;
    }
    std::vector<data::CoilSetIdentification> reports;
    ProgressBar bar("identify " + options->model);
    const auto on_progress = [&](const data::IdentifyProgress& p) {
      bar.update(p.fraction(), p.what + ", " + std::to_string(p.coil_sets) + " coil sets side by side");
    };
    data::IdentifySummary summary;
    ModelFile file = data::identify_motor(data, motor, options->identify, reports, on_progress, &summary);
    bar.finish();
    file.provenance.data_sha256 = sha256_file(options->data);
    file.provenance.generator = generator_name("identify");
    write_file_atomically(options->output, format_model_file(file));

    std::printf("%s model, %d coil sets; data-term cost (mean squared error) per direction y [N^2], x [N^2], z [N^2 m^2]\n",
                options->model.c_str(), motor.coil_sets);
    std::printf("coil set  data        physics-only                     %-6s                           Prop. 4.1\n",
                options->model.c_str());
    for (std::size_t l = 0; l < reports.size(); ++l) {
      const auto& r = reports[l].report;
      const bool holds = r.proposition_holds[0] && r.proposition_holds[1] && r.proposition_holds[2];
      std::printf("%-9zu training    %9.4g %9.4g %9.4g      %9.4g %9.4g %9.4g\n", l + 1, r.physics_training[0],
                  r.physics_training[1], r.physics_training[2], r.model_training[0], r.model_training[1],
                  r.model_training[2]);
      std::printf("%-9s validation  %9.4g %9.4g %9.4g      %9.4g %9.4g %9.4g\n", "", r.physics_validation[0],
                  r.physics_validation[1], r.physics_validation[2], r.model_validation[0], r.model_validation[1],
                  r.model_validation[2]);
      std::printf("%-9s %-11s %9.4g %9.4g %9.4g      %9.4g %9.4g %9.4g      %s (%d LM iterations, best restart %d)\n",
                  "", r.refit_on_all_data ? "all, in use" : "in use", r.physics_fit[0], r.physics_fit[1],
                  r.physics_fit[2], r.model_fit[0], r.model_fit[1], r.model_fit[2], holds ? "holds" : "VIOLATED",
                  r.iterations, r.best_restart + 1);
    }
    // Fit quality of the model put to use (docs/commutation.md, "Fit quality").
    for (std::size_t l = 0; l < reports.size(); ++l) {
      const auto& r = reports[l].report;
      std::printf("coil set %zu: regressor condition %.3g over %d linear parameters (%d dependent directions, %d "
                  "unexcited); %zu excitation gaps\n",
                  l + 1, r.regressors.condition, r.regressors.parameters, r.regressors.dependent,
                  r.regressors.unexcited, r.excitation_gaps.size());
      for (const auto& warning : identification::identification_warnings(r.regressors, r.excitation_gaps)) {
        std::fprintf(stderr, "clm identify: warning: coil set %zu: %s\n", l + 1, warning.c_str());
      }
    }
    if (summary.nuisance) {
      const auto& offset = summary.sensor_offset;
      std::printf("nuisance: sensor F_y offset %.4g N from the mechanics (m %.4g kg, f_v %.4g N s/m, f_c %.4g N, "
                  "residual RMS %.3g N, condition %.3g), removed from the data\n",
                  offset.offset_N, offset.mass_kg, offset.viscous_N_s_per_m, offset.coulomb_N, offset.residual_rms_N,
                  offset.condition);
      if (summary.direction_force) {
        std::printf("nuisance: direction-dependent force C*tanh(v/%.3g m/s) beside the model (variance inflation "
                    "%.3g); C per coil set [N, N, N m]:",
                    file.provenance.nuisance.direction_smoothing_m_per_s, summary.direction_force_inflation);
        for (const auto& c : file.provenance.nuisance.direction_force_N_N_Nm) {
          std::printf(" [%.3g, %.3g, %.3g]", c[0], c[1], c[2]);
        }
        std::printf("\n");
      } else {
        std::printf("nuisance: %s\n", summary.direction_force_skipped.c_str());
      }
    } else if (!summary.nuisance_skipped.empty()) {
      std::printf("nuisance: not identified: %s\n", summary.nuisance_skipped.c_str());
    }
    for (std::size_t k = 0; k < summary.trials.size(); ++k) {
      std::printf("capacity: %-24s validation score %.4g%s\n", summary.trials[k].capacity.c_str(),
                  summary.trials[k].validation_score, k == summary.chosen ? "  chosen" : "");
    }
    std::printf("wrote %s\n", options->output.c_str());
  });
}

}  // namespace clm::cli
