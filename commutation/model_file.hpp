#pragma once
// The files the tools and the daemon exchange (docs/model-format.md):
// the motor description, the calibration file (Algorithm 1) and the model file
// (PGNN or spline). Loading validates everything and throws clm::yaml::Error
// with file, line, key path and value; saving is exact (17 significant digits)
// so a file round-trips bit for bit.

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "commutation/calibration.hpp"
#include "commutation/classical.hpp"
#include "commutation/current_loop_compensation.hpp"
#include "commutation/encoder_reference.hpp"
#include "commutation/model.hpp"
#include "config/yaml_reader.hpp"

namespace clm {

/// The keys every tool needs of a motor (the daemon's config uses the same).
struct MotorDescription {
  double pole_pitch_m = 0.0;        ///< motor.pole_pitch_m, d_m
  int coil_sets = 0;                ///< motor.coil_sets, L
  double stroke_min_m = -0.1;       ///< motor.stroke_min_m: lower end of travel
  double stroke_max_m = 0.1;        ///< motor.stroke_max_m: upper end of travel
  /// motor.flexible_mode: the translator's first mode between the coils and
  /// the encoder, as a measured frequency response gives it (frequency_Hz,
  /// damping_ratio); 0 Hz when the file does not say (the position loop's
  /// margins then take the translator as rigid).
  double flexible_mode_Hz = 0.0;
  double flexible_mode_damping_ratio = 0.02;
  DriveCommutation drive;           ///< drive.commutation.*
  /// drive.profile: magnitude_phase (default) or phase_current. With
  /// phase_current the drive has no commutation of its own: drive.commutation
  /// is then the nominal law clm-servod applies itself where the drive's law
  /// is meant (commutation mode original, the experiments of Algorithm 1).
  DriveProfile drive_profile = DriveProfile::kMagnitudePhase;
  /// drive.watchdog_timeout_s: the drive's setpoint watchdog [s]; 0 when the
  /// file does not say (the timing margin then does not judge it).
  double drive_watchdog_timeout_s = 0.0;
  /// drive.current_loop: the drive's current loop as its manual gives it;
  /// absent, the currents are taken to follow their references at once.
  CurrentLoopModel current_loop;
  /// drive.setpoint_delay_s: from a setpoint's arrival at the drive to its
  /// current reference (bus, the drive's cycle and PWM update) [s];
  /// drive.position_delay_s: the age of the position the drive reports, at
  /// its sample (the encoder's and the drive's latency) [s]. 0 when the file
  /// does not say. The fit from positions pairs forces and positions with them.
  double setpoint_delay_s = 0.0;
  double position_delay_s = 0.0;
  /// What the reader accepts for either delay [s].
  static constexpr double kMaxDelay_s = 0.1;
};

/// Reads `motor:` and `drive.commutation:` of a YAML document; other top-level
/// sections belong to other readers and are left alone.
MotorDescription read_motor_description(const yaml::Node& root);
MotorDescription load_motor_description(const std::string& path);

/// The encoder reference a file's positions are in (docs/servod.md,
/// "Homing"): how the axis was homed and the axis position it gave the
/// latched event. `encoder_reference:` in calibration and model files;
/// absent in a file, an absolute encoder's ("none").
struct CalibrationFile {
  double pole_pitch_m = 0.0;
  EncoderReference reference;  ///< the frame of the experiments' positions
  DriveCommutation drive;  ///< the commutation the experiments ran with
  /// "algorithm1", "offset_robust", or "position" (Algorithm 1 on the
  /// driving force a position-identified model reconstructs).
  std::string method;
  struct CoilSet {
    ClassicalEstimate estimate;
    std::array<double, 2> delta_rad{};
    std::array<double, 2> gain_ratio{};
    std::array<double, 2> residual_rms_N{};
    /// `fit_quality` (optional: files written before it have none).
    std::optional<CalibrationQuality> quality;
  };
  std::vector<CoilSet> coil_sets;
  std::string data_sha256;
  std::string created_utc;
  std::string generator;

  std::vector<ClassicalEstimate> estimates() const;
};

std::string format_calibration_file(const CalibrationFile& file);
CalibrationFile parse_calibration_file(const yaml::Node& root);
CalibrationFile load_calibration_file(const std::string& path);

/// Per-direction costs [y, x, z] of one coil set: mean squared force error
/// (the data term of eq. 26) on training and validation data, for the
/// physics-only model and for the identified model.
struct CoilSetCosts {
  std::array<double, 3> physics_training{};
  std::array<double, 3> model_training{};
  std::array<double, 3> physics_validation{};
  std::array<double, 3> model_validation{};
  /// Fit quality of the model put to use (optional in the file: 0 and -1 when
  /// absent): the condition of its column-scaled linear regressors and the
  /// linear parameters its data leave unexcited (docs/commutation.md).
  double regressor_condition = 0.0;
  int unexcited_parameters = -1;
};

/// Nuisance terms identified beside the model (docs/commutation.md,
/// "Nuisance terms"). They are a record: no law uses them.
struct ModelNuisance {
  bool identified = false;
  /// Offset of the force sensor's F_y reading, removed from the data before
  /// identification [N] (F_x and T_z offsets are not observable: the guides
  /// carry those forces).
  double sensor_offset_y_N = 0.0;
  double direction_smoothing_m_per_s = 0.0;  ///< v_c of C·tanh(ẏ/v_c)
  std::vector<std::array<double, 3>> direction_force_N_N_Nm;  ///< C per coil set [N, N, N·m]
};

/// What each row of a model (F_y, F_x, T_z) was identified from.
enum class RowSource {
  kForceSensor,     ///< measured forces (the paper's identification)
  kPosition,        ///< positions and times through the mechanics (docs/commutation.md, "Without a force sensor")
  kDriveConstants,  ///< not identified: the physics model of the drive's constants, zero off the driving direction
};
const char* name(RowSource source);

struct ModelProvenance {
  std::string data_sha256;
  std::string created_utc;
  std::string generator;
  std::vector<CoilSetCosts> costs;  ///< one per coil set, or empty
  ModelNuisance nuisance;           ///< written only when identified
  /// `rows_from` (optional in the file: absent means all from the force sensor).
  std::array<RowSource, 3> rows_from{RowSource::kForceSensor, RowSource::kForceSensor, RowSource::kForceSensor};
};

struct ModelFile {
  ElectromagneticModel model;
  ModelProvenance provenance;
  EncoderReference reference;  ///< the frame of its positions (and of its identified range)
};

std::string format_model_file(const ModelFile& file);
ModelFile parse_model_file(const yaml::Node& root);
ModelFile load_model_file(const std::string& path);

/// Throws yaml::Error-style text naming both files when the model or
/// calibration was made for a different motor (coil sets, pole pitch).
void check_matches_motor(const ElectromagneticModel& model, const MotorDescription& motor,
                         const std::string& model_origin, const std::string& motor_origin);
void check_matches_motor(const CalibrationFile& calibration, const MotorDescription& motor,
                         const std::string& calibration_origin, const std::string& motor_origin);

}  // namespace clm
