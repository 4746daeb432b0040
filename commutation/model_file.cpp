#include "commutation/model_file.hpp"

#include <charconv>
#include <cmath>

namespace clm {
namespace {

constexpr const char* kModelFormat = "clm-servo-model";
constexpr const char* kCalibrationFormat = "clm-servo-calibration";
constexpr long kFormatVersion = 1;

void check_format(const yaml::Node& root, const char* expected) {
  root.expect_map();
  const std::string format = root["format"].as_string();
  if (format != expected) root["format"].fail("expected '" + std::string(expected) + "', got '" + format + "'");
  root["format_version"].as_integer_in(kFormatVersion, kFormatVersion);
}

bool relative_equal(double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(std::abs(a), std::abs(b)); }

void emit_network(YAML::Emitter& out, const Network& network) {
  out << YAML::BeginMap;
  out << YAML::Key << "hidden_sizes";
  const auto sizes = network.hidden_sizes();
  out << YAML::Flow << YAML::BeginSeq;
  for (int s : sizes) out << s;
  out << YAML::EndSeq;
  out << YAML::Key << "activation" << YAML::Value << "tanh";
  out << YAML::Key << "layers" << YAML::Value << YAML::BeginSeq;
  for (const auto& layer : network.layers) {
    out << YAML::BeginMap;
    out << YAML::Key << "weights" << YAML::Value;
    yaml::emit_matrix(out, layer.weights);
    out << YAML::Key << "biases" << YAML::Value;
    yaml::emit_double_list(out, layer.biases.data(), static_cast<std::size_t>(layer.biases.size()));
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
}

Network parse_network(const yaml::Node& node) {
  node.expect_keys({"hidden_sizes", "activation", "layers"});
  const std::string activation = node["activation"].as_string();
  if (activation != "tanh") node["activation"].fail("only 'tanh' is supported, got '" + activation + "'");
  const auto sizes = node["hidden_sizes"].as_int_list();
  const yaml::Node layers = node["layers"];
  if (layers.size() != sizes.size() + 1) {
    layers.fail(std::to_string(layers.size()) + " layers for hidden_sizes of length " +
                std::to_string(sizes.size()) + " (expected one more)");
  }
  Network network;
  int previous = 1;
  for (std::size_t i = 0; i < layers.size(); ++i) {
    const yaml::Node layer = layers.at(i);
    layer.expect_keys({"weights", "biases"});
    const int width = i < sizes.size() ? sizes[i] : Network::kOutputSize;
    if (width < 1 || width > Network::kMaxWidth) {
      node["hidden_sizes"].fail("width " + std::to_string(width) + " outside 1.." + std::to_string(Network::kMaxWidth));
    }
    DenseLayer dense;
    dense.weights = layer["weights"].as_matrix(width, previous);
    const auto biases = layer["biases"].as_double_list();
    if (static_cast<int>(biases.size()) != width) {
      layer["biases"].fail(std::to_string(biases.size()) + " biases, expected " + std::to_string(width));
    }
    dense.biases = Eigen::Map<const Eigen::VectorXd>(biases.data(), width);
    network.layers.push_back(std::move(dense));
    previous = width;
  }
  return network;
}

void emit_costs(YAML::Emitter& out, const char* key, const std::array<double, 3>& values) {
  out << YAML::Key << key << YAML::Value;
  yaml::emit_double_list(out, values.data(), values.size());
}

std::array<double, 3> parse_triple(const yaml::Node& node) {
  const auto values = node.as_double_list();
  if (values.size() != 3) node.fail("expected [y, x, z], got " + std::to_string(values.size()) + " values");
  return {values[0], values[1], values[2]};
}

std::array<double, 2> parse_pair(const yaml::Node& node) {
  const auto values = node.as_double_list();
  if (values.size() != 2) node.fail("expected two values, got " + std::to_string(values.size()));
  return {values[0], values[1]};
}

// Messages show the shortest text that reads back as the value (0.03, not
// the 17 digits 0.029999999999999999 the files use).
std::string shortest_text(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string optional_string(const yaml::Node& node, const char* key) {
  const auto child = node.optional(key);
  return child ? child->as_string() : std::string();
}

}  // namespace

MotorDescription read_motor_description(const yaml::Node& root) {
  MotorDescription motor;
  const yaml::Node section = root["motor"];
  section.expect_map();
  // The motor: section is this reader's alone (the simulator reads the same
  // keys), so a misspelt key is an error rather than a silent default.
  section.expect_keys({"pole_pitch_m", "coil_sets", "stroke_min_m", "stroke_max_m", "flexible_mode"});
  motor.pole_pitch_m = section["pole_pitch_m"].as_positive();
  motor.coil_sets = static_cast<int>(section["coil_sets"].as_integer_in(1, kMaxCoilSets));
  if (const auto low = section.optional("stroke_min_m")) motor.stroke_min_m = low->as_double();
  if (const auto high = section.optional("stroke_max_m")) motor.stroke_max_m = high->as_double();
  if (!(motor.stroke_max_m > motor.stroke_min_m)) {
    section.fail("stroke_max_m must be above stroke_min_m");
  }
  if (const auto mode = section.optional("flexible_mode")) {
    mode->expect_map();
    mode->expect_keys({"frequency_Hz", "damping_ratio"});
    motor.flexible_mode_Hz = (*mode)["frequency_Hz"].as_double_in(1.0, 1e5);
    if (const auto damping = mode->optional("damping_ratio")) {
      motor.flexible_mode_damping_ratio = damping->as_double_in(1e-4, 1.0);
    }
  }
  const yaml::Node commutation = root["drive"]["commutation"];
  commutation.expect_keys({"motor_constant_N_per_A", "phase_offset_rad"});
  motor.drive.motor_constant_N_per_A = commutation["motor_constant_N_per_A"].as_positive();
  motor.drive.phase_offset_rad = commutation["phase_offset_rad"].as_double_in(-2.0 * kPi, 2.0 * kPi);
  if (const auto profile = root["drive"].optional("profile")) {
    const std::string text = profile->as_string();
    if (text == "magnitude_phase") {
      motor.drive_profile = DriveProfile::kMagnitudePhase;
    } else if (text == "phase_current") {
      motor.drive_profile = DriveProfile::kPhaseCurrent;
    } else {
      profile->fail("must be magnitude_phase or phase_current, got '" + text + "'");
    }
  }
  if (const auto watchdog = root["drive"].optional("watchdog_timeout_s")) {
    motor.drive_watchdog_timeout_s = watchdog->as_positive();
  }
  if (const auto delay = root["drive"].optional("setpoint_delay_s")) {
    motor.setpoint_delay_s = delay->as_double_in(0.0, MotorDescription::kMaxDelay_s);
  }
  if (const auto delay = root["drive"].optional("position_delay_s")) {
    motor.position_delay_s = delay->as_double_in(0.0, MotorDescription::kMaxDelay_s);
  }
  if (const auto loop = root["drive"].optional("current_loop")) {
    loop->expect_map();
    loop->expect_keys({"bandwidth_Hz", "phase_resistance_ohm", "phase_inductance_H"});
    using Loop = CurrentLoopModel;
    motor.current_loop.bandwidth_Hz = (*loop)["bandwidth_Hz"].as_double_in(Loop::kMinBandwidth_Hz, Loop::kMaxBandwidth_Hz);
    motor.current_loop.phase_resistance_ohm =
        (*loop)["phase_resistance_ohm"].as_double_in(Loop::kMinResistance_ohm, Loop::kMaxResistance_ohm);
    motor.current_loop.phase_inductance_H =
        (*loop)["phase_inductance_H"].as_double_in(Loop::kMinInductance_H, Loop::kMaxInductance_H);
  }
  return motor;
}

MotorDescription load_motor_description(const std::string& path) {
  return read_motor_description(yaml::Node::load_file(path));
}

std::vector<ClassicalEstimate> CalibrationFile::estimates() const {
  std::vector<ClassicalEstimate> result;
  for (const auto& coil_set : coil_sets) result.push_back(coil_set.estimate);
  return result;
}

bool EncoderReference::same_frame(const EncoderReference& other) const noexcept {
  if (method != other.method) return false;
  return method == "none" || std::abs(position_m - other.position_m) <= 1e-9;
}

std::string EncoderReference::describe() const {
  if (method == "none") return "none (an absolute encoder)";
  return method + " at " + yaml::format_double(position_m) + " m";
}

namespace {

// Written for an incremental encoder only: a file without one is an
// absolute encoder's, as every file written before homing existed.
void emit_reference(YAML::Emitter& out, const EncoderReference& reference) {
  if (reference.method == "none") return;
  out << YAML::Key << "encoder_reference" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "method" << YAML::Value << reference.method;
  out << YAML::Key << "position_m" << YAML::Value << yaml::format_double(reference.position_m);
  out << YAML::EndMap;
}

EncoderReference parse_reference(const yaml::Node& root) {
  EncoderReference reference;
  const auto node = root.optional("encoder_reference");
  if (!node) return reference;
  node->expect_keys({"method", "position_m"});
  reference.method = (*node)["method"].as_string();
  if (std::find(kReferenceMethods.begin(), kReferenceMethods.end(), reference.method) == kReferenceMethods.end()) {
    (*node)["method"].fail("expected none, index, reference_switch or hard_stop, got '" + reference.method + "'");
  }
  reference.position_m = (*node)["position_m"].as_double_in(-10.0, 10.0);
  return reference;
}

}  // namespace

std::string format_calibration_file(const CalibrationFile& file) {
  YAML::Emitter out;
  out << YAML::Comment("clm-servo calibration (Algorithm 1); format in docs/model-format.md");
  out << YAML::BeginMap;
  out << YAML::Key << "format" << YAML::Value << kCalibrationFormat;
  out << YAML::Key << "format_version" << YAML::Value << kFormatVersion;
  out << YAML::Key << "method" << YAML::Value << file.method;
  out << YAML::Key << "motor" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "pole_pitch_m" << YAML::Value << yaml::format_double(file.pole_pitch_m);
  out << YAML::Key << "coil_sets" << YAML::Value << file.coil_sets.size();
  out << YAML::EndMap;
  emit_reference(out, file.reference);
  out << YAML::Key << "experiment_drive_commutation" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "motor_constant_N_per_A" << YAML::Value << yaml::format_double(file.drive.motor_constant_N_per_A);
  out << YAML::Key << "phase_offset_rad" << YAML::Value << yaml::format_double(file.drive.phase_offset_rad);
  out << YAML::EndMap;
  out << YAML::Key << "coil_sets" << YAML::Value << YAML::BeginSeq;
  for (const auto& coil_set : file.coil_sets) {
    out << YAML::BeginMap;
    out << YAML::Key << "motor_constant_N_per_A" << YAML::Value
        << yaml::format_double(coil_set.estimate.motor_constant_N_per_A);
    out << YAML::Key << "phase_offset_rad" << YAML::Value << yaml::format_double(coil_set.estimate.phase_offset_rad);
    out << YAML::Key << "delta_rad" << YAML::Value;
    yaml::emit_double_list(out, coil_set.delta_rad.data(), 2);
    out << YAML::Key << "gain_ratio" << YAML::Value;
    yaml::emit_double_list(out, coil_set.gain_ratio.data(), 2);
    out << YAML::Key << "residual_rms_N" << YAML::Value;
    yaml::emit_double_list(out, coil_set.residual_rms_N.data(), 2);
    if (coil_set.quality) {
      const CalibrationQuality& q = *coil_set.quality;
      out << YAML::Key << "fit_quality" << YAML::Value << YAML::BeginMap;
      out << YAML::Key << "gain_ratio_standard_error" << YAML::Value;
      yaml::emit_double_list(out, q.gain_ratio_standard_error, 2);
      out << YAML::Key << "separation_condition" << YAML::Value << yaml::format_double(q.separation_condition);
      out << YAML::Key << "offset_inflation" << YAML::Value;
      yaml::emit_double_list(out, q.offset_inflation, 2);
      out << YAML::EndMap;
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "provenance" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "data_sha256" << YAML::Value << YAML::DoubleQuoted << file.data_sha256;
  out << YAML::Key << "created_utc" << YAML::Value << YAML::DoubleQuoted << file.created_utc;
  out << YAML::Key << "generator" << YAML::Value << YAML::DoubleQuoted << file.generator;
  out << YAML::EndMap;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

CalibrationFile parse_calibration_file(const yaml::Node& root) {
  check_format(root, kCalibrationFormat);
  root.expect_keys({"format", "format_version", "method", "motor", "encoder_reference", "experiment_drive_commutation",
                    "coil_sets", "provenance"});
  CalibrationFile file;
  file.reference = parse_reference(root);
  file.method = root["method"].as_string();
  if (file.method != "algorithm1" && file.method != "offset_robust" && file.method != "position") {
    root["method"].fail("expected 'algorithm1', 'offset_robust' or 'position', got '" + file.method + "'");
  }
  const yaml::Node motor = root["motor"];
  motor.expect_keys({"pole_pitch_m", "coil_sets"});
  file.pole_pitch_m = motor["pole_pitch_m"].as_positive();
  const long coil_sets = motor["coil_sets"].as_integer_in(1, kMaxCoilSets);
  const yaml::Node drive = root["experiment_drive_commutation"];
  drive.expect_keys({"motor_constant_N_per_A", "phase_offset_rad"});
  file.drive.motor_constant_N_per_A = drive["motor_constant_N_per_A"].as_positive();
  file.drive.phase_offset_rad = drive["phase_offset_rad"].as_double();
  const yaml::Node list = root["coil_sets"];
  if (static_cast<long>(list.size()) != coil_sets) {
    list.fail(std::to_string(list.size()) + " entries, motor.coil_sets says " + std::to_string(coil_sets));
  }
  for (std::size_t l = 0; l < list.size(); ++l) {
    const yaml::Node entry = list.at(l);
    entry.expect_keys(
        {"motor_constant_N_per_A", "phase_offset_rad", "delta_rad", "gain_ratio", "residual_rms_N", "fit_quality"});
    CalibrationFile::CoilSet coil_set;
    coil_set.estimate.motor_constant_N_per_A = entry["motor_constant_N_per_A"].as_positive();
    coil_set.estimate.phase_offset_rad = entry["phase_offset_rad"].as_double_in(-2.0 * kPi, 2.0 * kPi);
    coil_set.delta_rad = parse_pair(entry["delta_rad"]);
    coil_set.gain_ratio = parse_pair(entry["gain_ratio"]);
    coil_set.residual_rms_N = parse_pair(entry["residual_rms_N"]);
    if (const auto quality = entry.optional("fit_quality")) {
      quality->expect_keys({"gain_ratio_standard_error", "separation_condition", "offset_inflation"});
      CalibrationQuality q;
      for (const char* key : {"gain_ratio_standard_error", "offset_inflation"}) {
        const yaml::Node node = (*quality)[key];
        const auto pair = parse_pair(node);
        if (pair[0] < 0.0 || pair[1] < 0.0) node.fail("expected two values >= 0");
        double* target = key == std::string("offset_inflation") ? q.offset_inflation : q.gain_ratio_standard_error;
        target[0] = pair[0];
        target[1] = pair[1];
      }
      q.separation_condition = (*quality)["separation_condition"].as_positive();
      coil_set.quality = q;
    }
    file.coil_sets.push_back(coil_set);
  }
  if (const auto provenance = root.optional("provenance")) {
    provenance->expect_keys({"data_sha256", "created_utc", "generator"});
    file.data_sha256 = optional_string(*provenance, "data_sha256");
    file.created_utc = optional_string(*provenance, "created_utc");
    file.generator = optional_string(*provenance, "generator");
  }
  return file;
}

CalibrationFile load_calibration_file(const std::string& path) {
  return parse_calibration_file(yaml::Node::load_file(path));
}

std::string format_model_file(const ModelFile& file) {
  const auto& model = file.model;
  model.validate();
  YAML::Emitter out;
  out << YAML::Comment("clm-servo electromagnetic model; format in docs/model-format.md");
  out << YAML::BeginMap;
  out << YAML::Key << "format" << YAML::Value << kModelFormat;
  out << YAML::Key << "format_version" << YAML::Value << kFormatVersion;
  out << YAML::Key << "kind" << YAML::Value << (model.kind == ModelKind::kPgnn ? "pgnn" : "spline");
  out << YAML::Key << "motor" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "pole_pitch_m" << YAML::Value << yaml::format_double(model.pole_pitch_m);
  out << YAML::Key << "coil_sets" << YAML::Value << model.coil_set_count();
  out << YAML::EndMap;
  emit_reference(out, file.reference);
  if (model.kind == ModelKind::kPgnn) {
    out << YAML::Key << "position_normalisation" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "offset_m" << YAML::Value << yaml::format_double(model.normalisation.offset_m);
    out << YAML::Key << "scale_m" << YAML::Value << yaml::format_double(model.normalisation.scale_m);
    out << YAML::EndMap;
    if (!model.harmonics.empty()) {
      out << YAML::Key << "harmonic_orders" << YAML::Value << YAML::BeginMap;
      for (const auto& [key, orders] :
           {std::pair{"gain", &model.harmonics.gain}, std::pair{"cogging", &model.harmonics.cogging}}) {
        out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginSeq;
        for (int n : *orders) out << n;
        out << YAML::EndSeq;
      }
      out << YAML::EndMap;
    }
  } else {
    out << YAML::Key << "spline_knots" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "start_m" << YAML::Value << yaml::format_double(model.spline_basis.start_m);
    out << YAML::Key << "end_m" << YAML::Value << yaml::format_double(model.spline_basis.end_m);
    out << YAML::Key << "intervals" << YAML::Value << model.spline_basis.intervals;
    out << YAML::EndMap;
  }
  out << YAML::Key << "coil_sets" << YAML::Value << YAML::BeginSeq;
  for (const auto& coil_set : model.coil_sets) {
    out << YAML::BeginMap;
    out << YAML::Key << "A_N_per_A" << YAML::Value;
    yaml::emit_matrix(out, coil_set.a_N_per_A);
    out << YAML::Key << "B_N_per_A" << YAML::Value;
    yaml::emit_matrix(out, coil_set.b_N_per_A);
    if (model.kind == ModelKind::kPgnn) {
      out << YAML::Key << "column_a" << YAML::Value;
      emit_network(out, coil_set.column_a);
      out << YAML::Key << "column_b" << YAML::Value;
      emit_network(out, coil_set.column_b);
      out << YAML::Key << "cogging" << YAML::Value;
      emit_network(out, coil_set.cogging);
      if (!model.harmonics.gain.empty()) {
        out << YAML::Key << "gain_harmonics_N_per_A" << YAML::Value;
        yaml::emit_matrix(out, coil_set.gain_harmonics_N_per_A);
      }
      if (!model.harmonics.cogging.empty()) {
        out << YAML::Key << "cogging_harmonics_N_N_Nm" << YAML::Value;
        yaml::emit_matrix(out, coil_set.cogging_harmonics_N);
      }
    } else {
      out << YAML::Key << "column_a_spline" << YAML::Value;
      yaml::emit_matrix(out, coil_set.column_a_spline);
      out << YAML::Key << "column_b_spline" << YAML::Value;
      yaml::emit_matrix(out, coil_set.column_b_spline);
      out << YAML::Key << "cogging_spline" << YAML::Value;
      yaml::emit_matrix(out, coil_set.cogging_spline);
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  const auto& provenance = file.provenance;
  out << YAML::Key << "provenance" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "data_sha256" << YAML::Value << YAML::DoubleQuoted << provenance.data_sha256;
  out << YAML::Key << "created_utc" << YAML::Value << YAML::DoubleQuoted << provenance.created_utc;
  out << YAML::Key << "generator" << YAML::Value << YAML::DoubleQuoted << provenance.generator;
  out << YAML::Key << "costs" << YAML::Value << YAML::BeginSeq;
  for (const auto& costs : provenance.costs) {
    out << YAML::BeginMap;
    emit_costs(out, "physics_training_N2", costs.physics_training);
    emit_costs(out, "model_training_N2", costs.model_training);
    emit_costs(out, "physics_validation_N2", costs.physics_validation);
    emit_costs(out, "model_validation_N2", costs.model_validation);
    if (costs.regressor_condition > 0.0) {
      out << YAML::Key << "regressor_condition" << YAML::Value << yaml::format_double(costs.regressor_condition);
    }
    if (costs.unexcited_parameters >= 0) {
      out << YAML::Key << "unexcited_parameters" << YAML::Value << costs.unexcited_parameters;
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (provenance.rows_from != ModelProvenance{}.rows_from) {
    out << YAML::Key << "rows_from" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const RowSource source : provenance.rows_from) out << name(source);
    out << YAML::EndSeq;
  }
  if (provenance.nuisance.identified) {
    const auto& nuisance = provenance.nuisance;
    out << YAML::Key << "nuisance" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "sensor_offset_y_N" << YAML::Value;
    out << yaml::format_double(nuisance.sensor_offset_y_N);
    out << YAML::Key << "direction_smoothing_velocity_m_per_s" << YAML::Value;
    out << yaml::format_double(nuisance.direction_smoothing_m_per_s);
    out << YAML::Key << "direction_force_N_N_Nm" << YAML::Value << YAML::BeginSeq;
    for (const auto& force : nuisance.direction_force_N_N_Nm) yaml::emit_double_list(out, force.data(), force.size());
    out << YAML::EndSeq;
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

const char* name(RowSource source) {
  switch (source) {
    case RowSource::kForceSensor:
      return "force_sensor";
    case RowSource::kPosition:
      return "position";
    case RowSource::kDriveConstants:
      return "drive_constants";
  }
  return "?";
}

ModelFile parse_model_file(const yaml::Node& root) {
  check_format(root, kModelFormat);
  ModelFile file;
  file.reference = parse_reference(root);
  auto& model = file.model;
  const std::string kind = root["kind"].as_string();
  if (kind == "pgnn") {
    model.kind = ModelKind::kPgnn;
    root.expect_keys({"format", "format_version", "kind", "motor", "encoder_reference", "position_normalisation",
                      "harmonic_orders", "coil_sets", "provenance"});
    const yaml::Node normalisation = root["position_normalisation"];
    normalisation.expect_keys({"offset_m", "scale_m"});
    model.normalisation.offset_m = normalisation["offset_m"].as_double();
    model.normalisation.scale_m = normalisation["scale_m"].as_positive();
    if (root.has("harmonic_orders")) {
      const yaml::Node orders = root["harmonic_orders"];
      orders.expect_keys({"gain", "cogging"});
      const auto read = [&](const char* key, int lowest) {
        const yaml::Node list = orders[key];
        const auto values = list.as_int_list();
        const std::string error = harmonic_orders_error(values, lowest);
        if (!error.empty()) list.fail(error);
        return values;
      };
      model.harmonics.gain = read("gain", kLowestGainHarmonic);
      model.harmonics.cogging = read("cogging", kLowestCoggingHarmonic);
    }
  } else if (kind == "spline") {
    model.kind = ModelKind::kSpline;
    root.expect_keys({"format", "format_version", "kind", "motor", "encoder_reference", "spline_knots", "coil_sets",
                      "provenance"});
    const yaml::Node knots = root["spline_knots"];
    knots.expect_keys({"start_m", "end_m", "intervals"});
    model.spline_basis.start_m = knots["start_m"].as_double();
    model.spline_basis.end_m = knots["end_m"].as_double();
    model.spline_basis.intervals = static_cast<int>(knots["intervals"].as_integer_in(1, 100000));
    if (!(model.spline_basis.end_m > model.spline_basis.start_m)) knots["end_m"].fail("must be above start_m");
  } else {
    root["kind"].fail("expected 'pgnn' or 'spline', got '" + kind + "'");
  }
  const yaml::Node motor = root["motor"];
  motor.expect_keys({"pole_pitch_m", "coil_sets"});
  model.pole_pitch_m = motor["pole_pitch_m"].as_positive();
  const long coil_sets = motor["coil_sets"].as_integer_in(1, kMaxCoilSets);
  const yaml::Node list = root["coil_sets"];
  if (static_cast<long>(list.size()) != coil_sets) {
    list.fail(std::to_string(list.size()) + " entries, motor.coil_sets says " + std::to_string(coil_sets));
  }
  for (std::size_t l = 0; l < list.size(); ++l) {
    const yaml::Node entry = list.at(l);
    CoilSetModel coil_set;
    if (model.kind == ModelKind::kPgnn) {
      entry.expect_keys({"A_N_per_A", "B_N_per_A", "column_a", "column_b", "cogging", "gain_harmonics_N_per_A",
                         "cogging_harmonics_N_N_Nm"});
      coil_set.column_a = parse_network(entry["column_a"]);
      coil_set.column_b = parse_network(entry["column_b"]);
      coil_set.cogging = parse_network(entry["cogging"]);
      // Present exactly when harmonic_orders lists orders of their kind.
      const auto harmonics = [&](const char* key, std::size_t orders, int per_order) {
        if (orders == 0) {
          if (entry.has(key)) entry[key].fail("no harmonic_orders of this kind are given");
          return Eigen::Matrix<double, 3, Eigen::Dynamic>(3, 0);
        }
        return Eigen::Matrix<double, 3, Eigen::Dynamic>(
            entry[key].as_matrix(3, per_order * static_cast<int>(orders)));
      };
      coil_set.gain_harmonics_N_per_A = harmonics("gain_harmonics_N_per_A", model.harmonics.gain.size(), 4);
      coil_set.cogging_harmonics_N = harmonics("cogging_harmonics_N_N_Nm", model.harmonics.cogging.size(), 2);
    } else {
      entry.expect_keys({"A_N_per_A", "B_N_per_A", "column_a_spline", "column_b_spline", "cogging_spline"});
      const int n = model.spline_basis.size();
      coil_set.column_a_spline = entry["column_a_spline"].as_matrix(3, n);
      coil_set.column_b_spline = entry["column_b_spline"].as_matrix(3, n);
      coil_set.cogging_spline = entry["cogging_spline"].as_matrix(3, n);
    }
    coil_set.a_N_per_A = entry["A_N_per_A"].as_matrix(3, 2);
    coil_set.b_N_per_A = entry["B_N_per_A"].as_matrix(3, 2);
    model.coil_sets.push_back(std::move(coil_set));
  }
  const yaml::Node provenance = root["provenance"];
  provenance.expect_keys({"data_sha256", "created_utc", "generator", "costs", "nuisance", "rows_from"});
  file.provenance.data_sha256 = optional_string(provenance, "data_sha256");
  file.provenance.created_utc = optional_string(provenance, "created_utc");
  file.provenance.generator = optional_string(provenance, "generator");
  if (const auto costs = provenance.optional("costs")) {
    for (std::size_t l = 0; l < costs->size(); ++l) {
      const yaml::Node entry = costs->at(l);
      entry.expect_keys({"physics_training_N2", "model_training_N2", "physics_validation_N2", "model_validation_N2",
                         "regressor_condition", "unexcited_parameters"});
      CoilSetCosts record{parse_triple(entry["physics_training_N2"]), parse_triple(entry["model_training_N2"]),
                          parse_triple(entry["physics_validation_N2"]), parse_triple(entry["model_validation_N2"])};
      // A condition number is 1 or more.
      if (const auto condition = entry.optional("regressor_condition")) {
        record.regressor_condition = condition->as_double();
        if (!(record.regressor_condition >= 1.0)) condition->fail("a condition number is 1 or more");
      }
      if (const auto unexcited = entry.optional("unexcited_parameters")) {
        record.unexcited_parameters = static_cast<int>(unexcited->as_integer_in(0, 1000000));
      }
      file.provenance.costs.push_back(record);
    }
  }
  if (const auto rows_from = provenance.optional("rows_from")) {
    if (rows_from->size() != 3) rows_from->fail("three entries (F_y, F_x, T_z), not " + std::to_string(rows_from->size()));
    for (std::size_t q = 0; q < 3; ++q) {
      const yaml::Node entry = rows_from->at(q);
      const std::string text = entry.as_string();
      bool known = false;
      for (const RowSource source : {RowSource::kForceSensor, RowSource::kPosition, RowSource::kDriveConstants}) {
        if (text == name(source)) {
          file.provenance.rows_from[q] = source;
          known = true;
        }
      }
      if (!known) entry.fail("expected force_sensor, position or drive_constants");
    }
  }
  if (const auto nuisance = provenance.optional("nuisance")) {
    nuisance->expect_keys({"sensor_offset_y_N", "direction_smoothing_velocity_m_per_s", "direction_force_N_N_Nm"});
    auto& record = file.provenance.nuisance;
    record.identified = true;
    record.sensor_offset_y_N = (*nuisance)["sensor_offset_y_N"].as_double();
    record.direction_smoothing_m_per_s = (*nuisance)["direction_smoothing_velocity_m_per_s"].as_double();
    const yaml::Node forces = (*nuisance)["direction_force_N_N_Nm"];
    if (forces.size() != model.coil_sets.size()) {
      forces.fail(std::to_string(forces.size()) + " entries, the model has " + std::to_string(model.coil_sets.size()) +
                  " coil sets");
    }
    for (std::size_t l = 0; l < forces.size(); ++l) record.direction_force_N_N_Nm.push_back(parse_triple(forces.at(l)));
  }
  try {
    model.validate();
  } catch (const ModelError& e) {
    root.fail(e.what());
  }
  return file;
}

ModelFile load_model_file(const std::string& path) { return parse_model_file(yaml::Node::load_file(path)); }

void check_matches_motor(const ElectromagneticModel& model, const MotorDescription& motor,
                         const std::string& model_origin, const std::string& motor_origin) {
  if (model.coil_set_count() != motor.coil_sets) {
    throw yaml::Error(model_origin + ": motor.coil_sets: model has " + std::to_string(model.coil_set_count()) +
                      " coil sets, " + motor_origin + " has " + std::to_string(motor.coil_sets));
  }
  if (!relative_equal(model.pole_pitch_m, motor.pole_pitch_m)) {
    throw yaml::Error(model_origin + ": motor.pole_pitch_m: model has " + shortest_text(model.pole_pitch_m) +
                      " m, " + motor_origin + " has " + shortest_text(motor.pole_pitch_m) + " m");
  }
}

void check_matches_motor(const CalibrationFile& calibration, const MotorDescription& motor,
                         const std::string& calibration_origin, const std::string& motor_origin) {
  if (static_cast<int>(calibration.coil_sets.size()) != motor.coil_sets) {
    throw yaml::Error(calibration_origin + ": motor.coil_sets: calibration has " +
                      std::to_string(calibration.coil_sets.size()) + " coil sets, " + motor_origin + " has " +
                      std::to_string(motor.coil_sets));
  }
  if (!relative_equal(calibration.pole_pitch_m, motor.pole_pitch_m)) {
    throw yaml::Error(calibration_origin + ": motor.pole_pitch_m: calibration has " +
                      shortest_text(calibration.pole_pitch_m) + " m, " + motor_origin + " has " +
                      shortest_text(motor.pole_pitch_m) + " m");
  }
}

}  // namespace clm
