// clm commission: calibrate, identify and evaluate every commutation on the
// embedded simulated motor (or, with --live, on a running clm-servod over
// LCM), and write the report.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <vector>

#include "config/atomic_file.hpp"
#include "config/command_line.hpp"
#include "config/yaml_edit.hpp"
#include "tools/servod_client/config_update.hpp"
#include "tools/servod_client/stop_signals.hpp"

#include "tools/cli/commands.hpp"
#include "tools/cli/share_script.hpp"
#include "tools/commission/commission.hpp"

namespace clm::cli {

namespace {

// Where the package installs the default configuration (docs/packaging.md).
constexpr const char* kDefaultConfig = "/etc/clm-servo/servod.yaml";

std::string cell(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%9.3g", value);
  return buffer;
}

/// --save: the commissioned laws and the recommended law's feedforward into
/// the daemon's configuration, as absolute paths, with the recommended law as
/// the mode (the daemon reads them at its next start; with --live it has them
/// loaded already). The force sensor's calibration and PGNN when there are
/// any and the commissioning used them (not --no-force-sensor), else the
/// calibration from positions; the spline model of the law.
void save_result(const std::string& config_path, const std::string& out_dir, const std::string& law,
                 bool from_positions_only) {
  const std::string dir = std::filesystem::canonical(out_dir).string();
  const auto file = [&](const char* name) { return yaml::quoted(dir + "/" + name); };
  const bool forces = !from_positions_only && std::filesystem::exists(dir + "/calibration.yaml");
  const bool from_position = law == "spline-position";
  std::vector<servod_client::ConfigEdit> edits{
      {"commutation.calibration_file", file(forces ? "calibration.yaml" : "calibration-position.yaml")},
      {"commutation.spline_model_file", file(from_position ? "model-spline-position.yaml" : "model-spline.yaml")},
      {"control.feedforward_file", yaml::quoted(dir + "/feedforward-" + law + ".yaml")},
      {"control.feedforward", std::nullopt},
      {"commutation.mode", from_position ? std::string("spline") : law},
  };
  if (forces) edits.insert(edits.begin() + 1, {"commutation.pgnn_model_file", file("model-pgnn.yaml")});
  const auto update = servod_client::update_config_file(config_path, edits);
  std::printf("saved: %s now starts with the %s law and feedforward of %s (the previous file is %s)\n",
              update.path.c_str(), law.c_str(), dir.c_str(), update.backup_path.c_str());
}

}  // namespace

void add_commission(CLI::App& app) {
  auto* sub = app.add_subcommand("commission",
                                 "calibrate, identify and evaluate all commutations on the embedded simulated motor, "
                                 "or with --live on a running clm-servod over LCM");
  sub->footer("With --live on a host whose CPU is not reserved for the loop, late wake-ups trip a short drive "
              "watchdog (fault 206) and faults.overrun_limit (fault 205): keep the drive's watchdog several times "
              "above the wake-up latency clm ctl status shows (the simulated drive: drive.watchdog_timeout_s 0.1 to 1) and "
              "raise faults.overrun_limit (the shipped configuration: 100); docs/bring-up.md, section 6.\n"
              "Before its first experiment --live checks --out (file directories, free space), every program "
              "against the daemon's limits, the daemon's motor and drive profile, and the timing margin (watchdog "
              "at least the period + 3 x the measured max wake-up latency); it refuses with every reason and fix "
              "(exit 2). A live commissioning ended early resumes with --resume DIR instead of --out DIR: the "
              "experiments it completed are reused (docs/commissioning.md, \"Resuming\").");
  struct Options {
    commission::Options run;
    bool plots = true;
    bool save = false;
  };
  auto options = std::make_shared<Options>();
  options->run.config_path = kDefaultConfig;
  sub->add_option("--config", options->run.config_path, "daemon configuration (YAML); the default is where the package installs it")
      ->check(CLI::ExistingFile)
      ->capture_default_str();
  auto* out = sub->add_option("--out", options->run.out_dir, "output directory");
  auto* resume = sub->add_option("--resume", options->run.out_dir,
                                 "--live: resume the interrupted live commissioning in DIR (its --out): the "
                                 "experiments it completed are reused when the daemon runs the same configuration, "
                                 "motor and experiment program and their logs are intact; the rest runs")
                     ->type_name("DIR");
  out->excludes(resume);
  sub->add_option("--program", options->run.program_path,
                  "evaluation program: feedforward data and the evaluation of every law (default: programs/fig8.yaml "
                  "beside the config)")
      ->check(CLI::ExistingFile);
  sub->add_option("--experiment-program", options->run.experiment_program_path,
                  "experiment program of calibration and identification (default: programs/identification.yaml beside "
                  "the config)")
      ->check(CLI::ExistingFile);
  sub->add_option("--validation-program", options->run.validation_program_path,
                  "held-out program (default: programs/validation.yaml beside the config; none: skip)");
  sub->add_flag("--live", options->run.live,
                "run every experiment on a running clm-servod over LCM (it must read this config and share this "
                "file system: files are sent as absolute paths)");
  sub->add_option("--lcm-url", options->run.live_options.lcm_url,
                  "--live: LCM URL of the daemon; default: $CLM_SERVO_LCM_URL, else the configuration's "
                  "telemetry.lcm_url");
  sub->add_option("--key-file", options->run.live_options.key_file,
                  "--live: the operators' key shared with the daemon (its commands.key_file); default: "
                  "$CLM_SERVO_KEY_FILE, else /etc/clm-servo/command.key");
  sub->add_option("--ack-timeout-s", options->run.live_options.ack_timeout_s,
                  "--live: how long each command waits for its CLM_SERVO_COMMAND_ACK [s]")
      ->check(clm::positive_number())
      ->capture_default_str();
  sub->add_option("--attempts-per-run", options->run.live_options.attempts_per_run,
                  "--live: a run with missing CLM_SERVO_STATE messages is repeated up to this many attempts in all")
      ->check(clm::in_range(1, 100))
      ->capture_default_str();
  sub->add_option("--restarts", options->run.identify.pgnn.restarts, "PGNN restarts")->check(clm::in_range(1, 1000))->capture_default_str();
  sub->add_option("--seed", options->run.identify.pgnn.seed, "seed of the PGNN restarts")->capture_default_str();
  sub->add_flag("!--no-nuisance", options->run.identify.nuisance,
                "identify the models alone, as the paper does (default: the sensor's F_y offset and the "
                "direction-dependent force beside them)");
  sub->add_flag("!--no-selection", options->run.identify.select_capacity,
                "the paper's PGNN (2/16 neurons, Lambda 0.1) and knots at pole pitch / 8 (default: chosen from a grid "
                "by validation error)");
  sub->add_flag("--no-force-sensor", options->run.no_force_sensor,
                "also commission from positions alone: the experiments without their force columns give "
                "classical-position and spline-position, evaluated beside the force-sensor laws");
  auto* mass = sub->add_option("--mass-kg", options->run.position.motion.mass_kg,
                               "--no-force-sensor: the translator's mass, which fixes the force scale (default: "
                               "control.mass_kg of --config; 0: the drive's nominal commutation sets the scale)")
                   ->check(clm::non_negative_number());
  auto* payload = sub->add_option("--payload-kg", options->run.payload_kg,
                                  "--no-force-sensor: a known payload [kg] mounted for a second run of the "
                                  "experiments; the two responses give the translator's mass, which sets the force "
                                  "scale (in process it is added to the simulated motor; --live asks the operator to "
                                  "mount it, with the axis disabled)")
                      ->check(clm::positive_number());
  sub->add_flag("!--no-plots", options->plots, "skip the PNG plots");
  sub->add_flag("--save", options->save,
                "keep the result: the calibration, both models, and the recommended law as the commutation mode with its "
                "feedforward go into --config (the previous file stays as FILE.bak)");
  add_friction_options(*sub, options->run.position.motion.viscous_N_s_per_m,
                       options->run.position.motion.direction_N);
  sub->callback([options, mass, payload, out, resume] {
    if (out->count() == 0 && resume->count() == 0) throw CLI::RequiredError("--out");
    options->run.resume = resume->count() > 0;
    if (options->run.resume && !options->run.live) {
      throw std::runtime_error("--resume: only a live commissioning resumes: give --live");
    }
    // A friction given, or a payload, sets the scale instead of the configuration's mass.
    const bool friction = options->run.position.motion.friction_given();
    if (const std::string refusal = commission::payload_refusal(options->run); !refusal.empty()) {
      throw CLI::ValidationError(refusal);
    }
    options->run.mass_from_config = mass->count() == 0 && !friction && payload->count() == 0;
    if (options->run.validation_program_path != "none" && !options->run.validation_program_path.empty() &&
        !std::filesystem::is_regular_file(options->run.validation_program_path)) {
      throw std::runtime_error("--validation-program: " + options->run.validation_program_path + ": no such file");
    }
    // Live: SIGINT and SIGTERM end the commissioning through its waits (the
    // runner then stops the axis and releases control, exit 1); the
    // deadman's renewals stop at once.
    if (options->run.live) servod_client::install_stop_signals();
    const auto start = std::chrono::steady_clock::now();
    const auto seconds_since = [](std::chrono::steady_clock::time_point from) {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - from).count();
    };
    ProgressBar bar("commission");
    std::string current;
    const auto report = commission::run(options->run, [&](const commission::Progress& p) {
      if (p.step != current) {
        if (!current.empty()) bar.finish();
        bar = ProgressBar(p.step);
        current = p.step;
      }
      bar.update(p.fraction, p.detail);
    });
    bar.finish();
    double plot_s = 0.0;
    bool plotted = false;
    if (options->plots) {
      // The plotter runs for seconds without output of its own: say so first.
      std::fprintf(stderr, "plots: drawing the PNG files into %s ...\n", options->run.out_dir.c_str());
      const auto plot_start = std::chrono::steady_clock::now();
      // The directory is incomplete again until every plot is drawn.
      commission::IncompleteMarker incomplete(options->run.out_dir, "drawing the plots");
      plotted = run_share_script("plot_report.py", {options->run.out_dir});
      incomplete.finished();
      plot_s = seconds_since(plot_start);
    }
    const commission::CommutationResult* oracle = nullptr;
    for (const auto& r : report.results) {
      if (r.name == "oracle" && r.evaluated) oracle = &r;
    }
    std::printf("\ncommutation         MSE y [N^2]  MSE x [N^2]  MSE z [N^2m^2]  true y [N^2]  static y [N^2]  tracking [m^2]  /oracle\n");
    for (const auto& r : report.results) {
      if (!r.evaluated) {
        std::printf("%-18s  not evaluated: %s\n", r.name.c_str(), r.skipped_reason.c_str());
        continue;
      }
      std::printf("%-18s  %s    %s    %s     %s       %s     %s  %s\n", r.name.c_str(), cell(r.mse.filtered[0]).c_str(),
                  cell(r.mse.filtered[1]).c_str(), cell(r.mse.filtered[2]).c_str(),
                  r.truth_known ? cell(r.true_mse.filtered[0]).c_str() : "        -",
                  r.truth_known ? cell(r.static_mse.filtered[0]).c_str() : "        -",
                  cell(r.tracking_mse_m2).c_str(),
                  oracle ? cell(r.tracking_mse_m2 / oracle->tracking_mse_m2).c_str() : "        -");
    }
    std::printf("(MSE of the measured force - F*, filtered; true y: the simulator's electromagnetic force over each cycle's period - its F*; "
                "static y: the law's force for F* on the static truth at the true position through an ideal drive - F*)\n");
    const commission::CommutationResult* classical = nullptr;
    const commission::CommutationResult* pgnn = nullptr;
    for (const auto& r : report.results) {
      if (r.name == "classical" && r.evaluated) classical = &r;
      if (r.name == "pgnn" && r.evaluated) pgnn = &r;
    }
    if (classical && pgnn) {
      std::printf("\nPGNN vs calibrated classical: commutation MSE y %.1fx lower, tracking MSE %.1fx lower "
                  "(paper: 11.2x and 4.6x)\n",
                  classical->mse.filtered[0] / pgnn->mse.filtered[0], classical->tracking_mse_m2 / pgnn->tracking_mse_m2);
    }
    if (const std::string line = commission::position_summary(report); !line.empty()) {
      std::printf("%s\n", line.c_str());
    }
    if (oracle) {
      std::printf("tracking MSE over the oracle's:");
      for (const auto& r : report.results) {
        if (r.evaluated && &r != oracle) std::printf(" %s %.2fx", r.name.c_str(), r.tracking_mse_m2 / oracle->tracking_mse_m2);
      }
      std::printf("\n");
    }
    if (const std::string line = commission::commutation_share_summary(report); !line.empty()) {
      std::printf("%s\n", line.c_str());
    }
    if (const std::string line = commission::error_budget_summary(report); !line.empty()) {
      std::printf("%s\n", line.c_str());
    }
    for (const CalibrationFile* file : {&report.calibration_paper, &report.calibration_robust}) {
      for (std::size_t l = 0; l < file->coil_sets.size(); ++l) {
        const auto& c = file->coil_sets[l];
        if (!c.quality) continue;
        for (const auto& warning : calibration_warnings(c.gain_ratio.data(), *c.quality)) {
          std::fprintf(stderr, "clm commission: warning: calibration (%s), coil set %zu: %s\n", file->method.c_str(),
                       l + 1, warning.c_str());
        }
      }
    }
    for (const auto* entries : {&report.pgnn, &report.spline}) {
      for (std::size_t l = 0; l < entries->size(); ++l) {
        const auto& r = (*entries)[l].report;
        for (const auto& warning : identification::identification_warnings(r.regressors, r.excitation_gaps)) {
          std::fprintf(stderr, "clm commission: warning: identification (%s), coil set %zu: %s\n",
                       entries == &report.pgnn ? "pgnn" : "spline", l + 1, warning.c_str());
        }
      }
    }
    if (!report.recommended.empty()) {
      std::printf("recommended for service: %s; %s\n", report.recommended.c_str(), report.recommendation.c_str());
    }
    if (report.live.live) {
      std::printf("live: %d runs over %s, %lld program cycles recorded, %lld CLM_SERVO_STATE missing in the runs kept, "
                  "%d runs repeated after missing states\n",
                  report.live.runs, report.live.lcm_url.c_str(), static_cast<long long>(report.live.states_recorded),
                  static_cast<long long>(report.live.states_missing_kept), report.live.runs_repeated);
    }
    // The wall time of the whole command, the plots included; report.json's
    // total_wall_time_s is the pipeline's alone.
    std::printf("report: %s/report.md, %s/report.json%s; wall time %.1f s (commissioning %.1f s, plots %.1f s)\n",
                options->run.out_dir.c_str(), options->run.out_dir.c_str(), plotted ? ", plots" : " (no plots)",
                seconds_since(start), report.total_wall_s, plot_s);
    if (options->save) {
      save_result(options->run.config_path, options->run.out_dir, report.recommended, options->run.no_force_sensor);
    }
  });
}

}  // namespace clm::cli
