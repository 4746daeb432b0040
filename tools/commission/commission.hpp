#pragma once
// `clm commission`: calibrate and identify a motor and evaluate every
// commutation on the paper's Fig. 8 reference, as in the paper's Sec. 5:
//  1. Algorithm 1/2 experiments: each coil set alone, Δ = ±π/4, no feedforward;
//  2. calibration (paper and offset-robust), PGNN and spline identification;
//  3. per commutation: feedforward identification, then the evaluation run;
//  4. report.json, report.md, CSV data for the plots.

#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "daemon/control/metrics.hpp"
#include "daemon/control/tracking_split.hpp"
#include "tools/commission/progress.hpp"
#include "tools/commission/runner.hpp"
#include "tools/commission/runs.hpp"
#include "tools/data/commissioning_steps.hpp"
#include "tools/data/position_model.hpp"

namespace clm::commission {

struct Options {
  std::string config_path;
  std::string out_dir;
  data::IdentifyOptions identify;
  /// Evaluation reference: feedforward data and the evaluation of every
  /// commutation (the paper's Fig. 8 unless replaced).
  std::string program_path;
  /// Experiments of calibration and identification (programs/identification.yaml
  /// beside the config unless replaced: several speeds and accelerations,
  /// which the nuisance terms need; docs/commissioning.md).
  std::string experiment_program_path;
  /// Held-out trajectory on which every commutation is evaluated as well
  /// (programs/validation.yaml beside the config unless replaced; "none" skips).
  std::string validation_program_path;
  /// Run every experiment on a separately running clm-servod over LCM
  /// (LcmRunner) instead of the in-process simulated motor.
  bool live = false;
  LiveOptions live_options;
  /// --resume (live only): out_dir holds an interrupted live commissioning;
  /// its completed experiments (progress.hpp) are reused, the rest run.
  bool resume = false;
  /// Live: the daemon's configuration and motor (from its status) and the
  /// experiment program the runs are made with; run() sets it.
  RunIdentity identity;
  /// Commission from positions as an axis without a force sensor would
  /// (docs/commissioning.md, "Without a force sensor"): the same experiments
  /// without their force columns give classical-position and
  /// spline-position, with the mass of the configuration or position.motion.mass_kg,
  /// evaluated beside the force-sensor laws when there is a sensor.
  /// Without this flag a force sensor's commissioning identifies
  /// spline-position too, with the mass of its mechanics fit.
  bool no_force_sensor = false;
  data::PositionIdentifyOptions position;
  /// The mass prior of the identification from positions is the
  /// configuration's control.mass_kg (the mass the loop is tuned for), not
  /// position.motion.mass_kg (whose 0 lets the drive's nominal commutation set the scale).
  bool mass_from_config = true;
  /// With no_force_sensor: a known payload [kg] (> 0) mounted for a second
  /// run of the experiments; the two responses give the translator's mass,
  /// which sets the force scale instead of the configuration's
  /// (docs/commissioning.md, "The force scale from a known payload").
  double payload_kg = 0.0;
};

/// Why `options`' payload cannot be used, "" when it can or when there is
/// none: the payload gives the mass of the commissioning from positions, so
/// it needs no_force_sensor, a positive finite payload_kg, and neither a
/// mass (position.motion.mass_kg) nor a friction that would set the scale.
std::string payload_refusal(const Options& options);

struct CommutationResult {
  std::string name;
  bool evaluated = false;
  std::string skipped_reason;
  control::FeedforwardParameters feedforward{};
  control::DirectionMse mse{};  ///< measured wrench − F*
  /// The simulator's true electromagnetic wrench over each cycle's period,
  /// without the direction-dependent force and the sensor's bias and noise,
  /// − F*: the force the axis got against the one asked for, the drive's
  /// lag included. Only with a simulator in this process.
  bool truth_known = false;
  control::DirectionMse true_mse{};
  /// The law's static error: Recording::static_wrench − F*, the law's model
  /// against the static truth at the operating points of the run, without
  /// the drive, the encoder or the cycle's timing (an exact inverse scores
  /// zero). With truth_known.
  control::DirectionMse static_mse{};
  double tracking_mse_m2 = 0.0;
  /// The tracking error split by the commutation's own frequencies
  /// (control::split_tracking_error): what a live axis can tell without a
  /// simulator's oracle (docs/commissioning.md, "The error budget").
  control::TrackingSplit tracking_split{};
  double mean_current_square_A2 = 0.0;
  std::int64_t damping_cycles = 0;
  std::int64_t force_limited_cycles = 0;
};

/// The dynamic error budget of the laws' tracking MSE on the evaluation
/// program, in simulation (docs/commissioning.md, "The error budget"): the
/// oracle run again on the same plant with each error source alone
/// (sim::ErrorSources), its feedforward and the daemon as commissioned. The
/// sources' parts are every law's; each law adds its commutation's
/// (LawBudget). Uncorrelated sources through a linear loop add in MSE; what
/// the parts do not add up to is their interaction.
struct ErrorBudget {
  bool computed = false;        ///< false: live, or the oracle not evaluated
  double loop_m2 = 0.0;         ///< the oracle's with no source: the loop through the plant's dynamics [m²]
  double disturbance_m2 = 0.0;  ///< the oracle's with the force disturbance alone, − loop_m2 [m²]
  double encoder_m2 = 0.0;      ///< the oracle's with the encoder alone, − loop_m2 [m²]
};

/// One law's budget: its tracking MSE with every source on, its
/// commutation's part (its MSE − the oracle's), and the sum of the parts.
struct LawBudget {
  std::string law;
  double whole_m2 = 0.0;
  double commutation_m2 = 0.0;
  double sum_m2 = 0.0;
};
struct StepTime {
  std::string step;
  double wall_s = 0.0;
};

struct Report {
  std::string config_path;
  /// The frame of every position the experiments recorded (the axis's
  /// homing:), recorded in report.json and in every file made from them.
  EncoderReference encoder_reference;
  int coil_sets = 0;
  CalibrationFile calibration_paper;
  CalibrationFile calibration_robust;
  std::vector<data::CoilSetIdentification> pgnn;
  std::vector<data::CoilSetIdentification> spline;
  /// Nuisance terms and the capacity trials of each class (docs/commutation.md).
  data::IdentifySummary pgnn_selection;
  data::IdentifySummary spline_selection;
  /// The law recommended for service ("pgnn", "spline", "spline-position" or "classical") and why.
  std::string recommended;
  std::string recommendation;
  /// The law the force models alone would be recommended by ("pgnn",
  /// "spline", "classical"; "" without a force sensor).
  std::string force_recommended;
  /// original, classical, pgnn-paper (the paper's 2/16 PGNN), pgnn (capacity
  /// chosen by validation), spline, [classical-position,] spline-position, oracle
  std::vector<CommutationResult> results;
  std::vector<CommutationResult> validation;  ///< the same on the held-out trajectory
  std::string validation_program;
  std::string experiment_program;  ///< absolute paths of the programs run
  std::string evaluation_program;
  std::vector<StepTime> steps;
  double total_wall_s = 0.0;
  std::vector<std::string> files;          ///< written, relative to the output directory
  std::vector<std::string> notes;          ///< adaptations made for this motor
  LiveSummary live;                        ///< live commissioning only (live.live)
  /// The identification and calibration from positions (Options::no_force_sensor,
  /// or beside the force models when their mechanics fit gives the mass).
  bool from_position = false;
  data::PositionIdentification position;
  std::string position_mass_source;  ///< where the mass came from, or why there is none
  /// The payload experiments (Options::payload_kg): the payload and the
  /// identified ratio (m + payload)/m; 0 without them.
  double payload_kg = 0.0;
  double payload_ratio = 0.0;
  /// The model from positions scored as the force models' capacity trials
  /// (data::position_validation_score); NaN without force data.
  double position_validation_score = std::numeric_limits<double>::quiet_NaN();
  data::HeldOutBlocks position_held_out;  ///< its per-block errors (empty where the score is NaN)
  CalibrationFile calibration_position;
  /// The laws that competed for the recommendation with their validation
  /// scores and standard errors, in the order of preference on a tie
  /// (kTieOrder; "classical" is the physics-only fit, score 1 per coil set).
  std::vector<data::LawScore> law_scores;
  /// Models the daemon would refuse to load (commutation/law_check.hpp, as
  /// clm-servod checks them: blended to the calibration beyond their range),
  /// by law name, with its reason: they do not compete for the recommendation.
  std::map<std::string, std::string> refused_laws;
  /// How `recommended` was chosen from law_scores; `decided_by` says
  /// "validation score" (a clear win), "tie rule", or "no force sensor"
  /// (commissioned from positions: the verdict of the scores is
  /// force_recommended's, and `verdict` has no runner-up).
  data::Verdict verdict;
  std::string decided_by;
  ErrorBudget budget;  ///< in simulation (budget.computed)
};

/// The file a run keeps in its output directory from the directory's
/// creation until report.json and report.md are written, and again while
/// the plots are drawn.
inline constexpr const char* kIncompleteMarker = "INCOMPLETE";

/// Writes kIncompleteMarker into `dir`, saying which `stage` has not
/// finished; finished() removes it. A run stopped before (Ctrl-C, a
/// refusal, a crash) leaves it behind: the destructor does not remove it.
class IncompleteMarker {
 public:
  IncompleteMarker(const std::string& dir, const std::string& stage);
  void finished();

 private:
  std::string path_;
};

struct Progress {
  std::string step;
  double fraction = 0.0;
  std::string detail;
};

/// Runs the whole commissioning against the configuration's embedded
/// simulated motor on the virtual clock, or with options.live against a
/// running clm-servod over LCM. Writes into options.out_dir (created after
/// the daemon accepted the first command) with atomic writes. Throws with a
/// precise message.
Report run(const Options& options, const std::function<void(const Progress&)>& progress = {});

/// The same pipeline on a given runner.
Report run(const Options& options, ExperimentRunner& runner, const std::function<void(const Progress&)>& progress = {});

/// The report as JSON (docs/report-format.md) and as Markdown with the
/// paper's Table 2 beside ours.
std::string report_json(const Report& report);
std::string report_markdown(const Report& report);

/// Feedforward (40) identified from a run without feedforward: the reference
/// and the force command F* of every sample (control::identify_feedforward).
control::FeedforwardParameters identify_ff(const Recording& run);

/// One line comparing the laws from positions with the force-sensor ones
/// (tracking, true y error, identification wall time); "" without them.
std::string position_summary(const Report& report);

/// One line: the share of the recommended law's tracking MSE its commutation
/// causes, 1 − the oracle's tracking MSE over the law's (in simulation, where
/// every law meets the same disturbance and the oracle commutes exactly);
/// "" without the oracle or a recommendation.
std::string commutation_share_summary(const Report& report);

/// The budget of `law` in `report`; nullopt without a budget or without the
/// law's and the oracle's evaluation.
std::optional<LawBudget> law_budget(const Report& report, const std::string& law);

/// One line: the recommended law's error budget, each part's share of its
/// tracking MSE and their sum; "" without one (law_budget).
std::string error_budget_summary(const Report& report);

/// The laws in their order of preference when their validation scores tie
/// (docs/commutation.md, "The recommendation"): the calibrated classical law
/// (no model beats the physics-only fit by more than the noise), then the
/// spline (linear least squares, one optimum, F_y fit to the measured force),
/// the spline from positions (the same law in the cycle, its F_y through a
/// mechanics model), the PGNN (a network per cycle, one of many optima).
inline constexpr const char* kTieOrder[] = {"classical", "spline", "spline-position", "pgnn"};

/// Sets report.recommended, report.recommendation, report.law_scores,
/// report.verdict, report.decided_by and report.force_recommended from the
/// held-out blocks of the chosen PGNN and spline and of the spline from
/// positions: data::choose_law with data::kTieStandardErrors and kTieOrder
/// (docs/commutation.md, "The recommendation"). force_recommended is the same
/// choice without the spline from positions.
void recommend(Report& report);

/// How `verdict` was reached, in words: why the calibrated classical law is
/// kept (whether or not a model tied with it), the tie rule with the laws it
/// saw tied, or a clear win. The
/// console's recommendation line and report.md's verdict both say it so.
std::string verdict_reason(const data::Verdict& verdict);

/// The runner-up and its margin in score and in standard errors of the
/// paired difference, in words; "" without a runner-up.
std::string runner_up_margin(const data::Verdict& verdict);

/// Commutation MSE (filtered and unfiltered, y/x/z), tracking MSE and mean
/// current square of an evaluation run.
CommutationResult evaluate(const Recording& run, double period_s);

/// The tracking error of `run` split by the commutation's frequencies
/// (control::split_tracking_error) on the loop `config` describes (its
/// period, pole pitch, PID and control.mass_kg); all zero for a run too
/// short to split.
control::TrackingSplit split_tracking(const Recording& run, const servod::ServodConfig& config);

}  // namespace clm::commission
