// Model and calibration files: exact round trip, and refusal of corrupted or
// mismatched files with a message naming file, line and key.
#include <catch2/catch.hpp>
#include <random>
#include <regex>

#include "commutation/model_file.hpp"
#include "support/random_model.hpp"

using namespace clm;

namespace {

ModelFile random_model_file(ModelKind kind, int coil_sets, std::mt19937_64& rng) {
  ModelFile file;
  // Physics-part harmonics on every other PGNN file (optional keys).
  const HarmonicOrders harmonics = rng() % 2 == 0 ? HarmonicOrders{{5, 7}, {1, 2, 6}} : HarmonicOrders{};
  file.model = kind == ModelKind::kPgnn ? test::random_pgnn_model(coil_sets, 0.032, rng, {2}, {16}, harmonics)
                                        : test::random_spline_model(coil_sets, 0.032, rng);
  file.provenance = {"0123abcd", "2026-11-21T00:00:00Z", "test", {}, {}};
  for (int l = 0; l < coil_sets; ++l) file.provenance.costs.push_back({{1.0 / 3, 2, 3}, {0.1, 0.2, 0.3}, {4, 5, 6}, {0.4, 0.5, 0.6}});
  // Fit quality on every other file (optional keys), so that both forms are read back.
  if (rng() % 2 == 0) {
    file.provenance.costs[0].regressor_condition = 2719.0 + 1.0 / 3;
    file.provenance.costs[0].unexcited_parameters = 3;
  }
  // Rows from positions on every other file (optional key).
  if (rng() % 2 == 0) {
    file.provenance.rows_from = {RowSource::kPosition, RowSource::kDriveConstants, RowSource::kForceSensor};
  }
  // Nuisance terms on every other file, so that both forms are read back.
  if (rng() % 2 == 0) {
    auto& nuisance = file.provenance.nuisance;
    nuisance.identified = true;
    nuisance.sensor_offset_y_N = 0.1 + 1.0 / 3;
    nuisance.direction_smoothing_m_per_s = 0.002;
    for (int l = 0; l < coil_sets; ++l) nuisance.direction_force_N_N_Nm.push_back({-1.0 / 7, 0.1 * l, 0.03});
  }
  return file;
}

bool networks_equal(const Network& a, const Network& b) {
  if (a.layers.size() != b.layers.size()) return false;
  for (std::size_t i = 0; i < a.layers.size(); ++i) {
    if (a.layers[i].weights != b.layers[i].weights || a.layers[i].biases != b.layers[i].biases) return false;
  }
  return true;
}

std::string error_of(const std::string& text) {
  try {
    parse_model_file(yaml::Node::load_string(text, "model.yaml"));
  } catch (const yaml::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("model files round-trip bit for bit", "[model_file]") {
  std::mt19937_64 rng(30);
  for (auto kind : {ModelKind::kPgnn, ModelKind::kSpline}) {
    for (int coil_sets : {1, 3, 4}) {
      const ModelFile original = random_model_file(kind, coil_sets, rng);
      const std::string text = format_model_file(original);
      const ModelFile parsed = parse_model_file(yaml::Node::load_string(text, "model.yaml"));
      REQUIRE(parsed.model.kind == kind);
      REQUIRE(parsed.model.pole_pitch_m == original.model.pole_pitch_m);
      REQUIRE(parsed.model.coil_set_count() == coil_sets);
      REQUIRE(parsed.model.harmonics == original.model.harmonics);
      for (int l = 0; l < coil_sets; ++l) {
        const auto& a = original.model.coil_sets[static_cast<std::size_t>(l)];
        const auto& b = parsed.model.coil_sets[static_cast<std::size_t>(l)];
        REQUIRE(a.a_N_per_A == b.a_N_per_A);
        REQUIRE(a.b_N_per_A == b.b_N_per_A);
        REQUIRE(networks_equal(a.column_a, b.column_a));
        REQUIRE(networks_equal(a.column_b, b.column_b));
        REQUIRE(networks_equal(a.cogging, b.cogging));
        REQUIRE(a.gain_harmonics_N_per_A == b.gain_harmonics_N_per_A);
        REQUIRE(a.cogging_harmonics_N == b.cogging_harmonics_N);
        REQUIRE(a.column_a_spline == b.column_a_spline);
        REQUIRE(a.cogging_spline == b.cogging_spline);
      }
      REQUIRE(parsed.provenance.costs.size() == static_cast<std::size_t>(coil_sets));
      REQUIRE(parsed.provenance.costs[0].physics_training[0] == 1.0 / 3);
      REQUIRE(parsed.provenance.costs[0].regressor_condition == original.provenance.costs[0].regressor_condition);
      REQUIRE(parsed.provenance.costs[0].unexcited_parameters == original.provenance.costs[0].unexcited_parameters);
      const auto& nuisance = original.provenance.nuisance;
      REQUIRE(parsed.provenance.nuisance.identified == nuisance.identified);
      REQUIRE(parsed.provenance.nuisance.sensor_offset_y_N == nuisance.sensor_offset_y_N);
      REQUIRE(parsed.provenance.nuisance.direction_smoothing_m_per_s == nuisance.direction_smoothing_m_per_s);
      REQUIRE(parsed.provenance.nuisance.direction_force_N_N_Nm == nuisance.direction_force_N_N_Nm);
      REQUIRE(parsed.provenance.rows_from == original.provenance.rows_from);
      REQUIRE(format_model_file(parsed) == text);
    }
  }
}

TEST_CASE("corrupted model files are refused with file, line and key", "[model_file]") {
  std::mt19937_64 rng(31);
  ModelFile file = random_model_file(ModelKind::kPgnn, 2, rng);
  for (auto& costs : file.provenance.costs) costs = {costs.physics_training, costs.model_training,
                                                     costs.physics_validation, costs.model_validation};  // no fit quality
  const std::string text = format_model_file(file);
  const auto replace_first_in = [](const std::string& original, const std::string& from, const std::string& to) {
    std::string copy = original;
    const auto at = copy.find(from);
    REQUIRE(at != std::string::npos);
    copy.replace(at, from.size(), to);
    return copy;
  };
  const auto replace_first = [&](const std::string& from, const std::string& to) {
    return replace_first_in(text, from, to);
  };
  const std::regex located(R"(^model\.yaml:\d+: )");

  std::string error = error_of(replace_first("kind: pgnn", "kind: fourier"));
  CHECK(std::regex_search(error, located));
  CHECK(error.find("kind") != std::string::npos);

  error = error_of(replace_first("coil_sets: 2", "coil_sets: 3"));
  CHECK(error.find("coil_sets") != std::string::npos);

  const std::regex first_entry(R"(A_N_per_A: \[\[[^,]+)");
  error = error_of(std::regex_replace(text, first_entry, "A_N_per_A: [[nan", std::regex_constants::format_first_only));
  CHECK(std::regex_search(error, located));
  CHECK(error.find("coil_sets[0].A_N_per_A[0][0]") != std::string::npos);
  CHECK(error.find("not a finite number") != std::string::npos);

  error = error_of(std::regex_replace(text, first_entry, "A_N_per_A: [[1e999", std::regex_constants::format_first_only));
  CHECK(error.find("not a finite number") != std::string::npos);

  error = error_of(std::regex_replace(text, first_entry, "A_N_per_A: [[0.5, 0.1", std::regex_constants::format_first_only));
  CHECK(error.find("expected 2 columns, got 3") != std::string::npos);

  error = error_of(replace_first("hidden_sizes: [2]", "hidden_sizes: [3]"));
  CHECK(error.find("coil_sets[0].column_a") != std::string::npos);

  error = error_of(replace_first("scale_m:", "scale_mm: 1\n  scale_m:"));
  CHECK(error.find("unknown key 'scale_mm'") != std::string::npos);

  error = error_of(replace_first("format: clm-servo-model", "format: something-else"));
  CHECK(error.find("format") != std::string::npos);

  error = error_of(text.substr(0, text.size() / 2));
  CHECK_FALSE(error.empty());

  // Fit quality: a condition number is 1 or more, an unexcited count 0 or more.
  const std::string costs_entry = "      model_validation_N2: [0.40000000000000002, 0.5, 0.59999999999999998]\n";
  REQUIRE(text.find(costs_entry) != std::string::npos);
  error = error_of(replace_first(costs_entry, costs_entry + "      regressor_condition: 0.5\n"));
  CHECK(std::regex_search(error, located));
  CHECK(error.find("regressor_condition") != std::string::npos);
  error = error_of(replace_first(costs_entry, costs_entry + "      unexcited_parameters: -1\n"));
  CHECK(error.find("unexcited_parameters") != std::string::npos);
  CHECK(error_of(replace_first(costs_entry, costs_entry + "      regressor_condition: 12.5\n")).empty());

  // Where the rows came from: three known names.
  const std::string generator = "  generator: \"test\"\n";
  REQUIRE(text.find(generator) != std::string::npos);
  // The file's own rows_from out first: a key given twice is refused.
  const std::regex rows_from_line("  rows_from: \\[[^\\]]*\\]\n");
  REQUIRE(std::regex_search(text, rows_from_line));
  const std::string without_rows_from = std::regex_replace(text, rows_from_line, "");
  const auto rows_from = [&](const std::string& list) {
    return error_of(replace_first_in(without_rows_from, generator, generator + "  rows_from: " + list + "\n"));
  };
  error = error_of(replace_first(generator, generator + "  rows_from: [position, drive_constants, force_sensor]\n"));
  CHECK(std::regex_search(error, located));
  CHECK(error.find("provenance.rows_from: given twice (first on line") != std::string::npos);
  CHECK(rows_from("[position, drive_constants, force_sensor]").empty());
  error = rows_from("[position, drive_constants]");
  CHECK(std::regex_search(error, located));
  CHECK(error.find("three entries") != std::string::npos);
  error = rows_from("[position, guessed, force_sensor]");
  CHECK(std::regex_search(error, located));
  CHECK(error.find("expected force_sensor, position or drive_constants") != std::string::npos);

  // Physics-part harmonics: orders ascending, distinct and in range, with
  // coefficients of matching size in every coil set, and none without orders.
  ModelFile harmonic = file;
  harmonic.model = test::random_pgnn_model(2, 0.032, rng, {2}, {16}, {{5, 7}, {1, 6}});
  const std::string harmonic_text = format_model_file(harmonic);
  const auto edited = [&](const std::string& from, const std::string& to) {
    return error_of(replace_first_in(harmonic_text, from, to));
  };
  CHECK(error_of(harmonic_text).empty());
  for (const std::string orders : {"gain: [7, 5]", "gain: [1, 5]", "gain: [5, 5]", "gain: [5, 17]"}) {
    error = edited("gain: [5, 7]", orders);
    INFO(orders << ": " << error);
    CHECK(std::regex_search(error, located));
    CHECK(error.find("harmonic_orders.gain") != std::string::npos);
  }
  error = edited("gain: [5, 7]", "gain: [5]");
  CHECK(std::regex_search(error, located));
  CHECK(error.find("gain_harmonics_N_per_A") != std::string::npos);
  CHECK(error.find("expected 4 columns, got 8") != std::string::npos);
  error = edited("cogging: [1, 6]", "cogging: []");
  CHECK(error.find("cogging_harmonics_N_N_Nm") != std::string::npos);
  CHECK(error.find("no harmonic_orders of this kind") != std::string::npos);
}

TEST_CASE("spline knots whose spacing overflows or underflows are refused", "[model_file]") {
  // docs/fuzzing.md: evaluating such a model turned a NaN into a knot index.
  std::mt19937_64 rng(33);
  const std::string text = format_model_file(random_model_file(ModelKind::kSpline, 1, rng));
  const std::regex knots(R"(start_m: [^\n]+\n  end_m: [^\n]+\n)");
  for (const char* bounds : {"start_m: -1e308\n  end_m: 1e308\n",
                             "start_m: 2.2250738585072014e-308\n  end_m: 2.2250738585072019e-308\n"}) {
    const std::string corrupted = std::regex_replace(text, knots, bounds, std::regex_constants::format_first_only);
    REQUIRE(corrupted != text);
    INFO(bounds);
    CHECK_THAT(error_of(corrupted), Catch::Contains("model.yaml:") && Catch::Contains("finite, non-zero knot spacing"));
  }
}

TEST_CASE("a model for another motor is refused naming both files", "[model_file]") {
  std::mt19937_64 rng(32);
  const ModelFile file = random_model_file(ModelKind::kSpline, 3, rng);
  MotorDescription motor;
  motor.pole_pitch_m = 0.032;
  motor.coil_sets = 2;
  CHECK_THROWS_WITH(check_matches_motor(file.model, motor, "m.yaml", "motor.yaml"),
                    Catch::Contains("m.yaml") && Catch::Contains("motor.yaml") && Catch::Contains("coil sets"));
  motor.coil_sets = 3;
  motor.pole_pitch_m = 0.030;
  CHECK_THROWS_WITH(check_matches_motor(file.model, motor, "m.yaml", "motor.yaml"), Catch::Contains("pole_pitch_m"));
  motor.pole_pitch_m = 0.032;
  CHECK_NOTHROW(check_matches_motor(file.model, motor, "m.yaml", "motor.yaml"));
}

TEST_CASE("calibration files round-trip and refuse a wrong coil-set count", "[model_file]") {
  CalibrationFile file;
  file.pole_pitch_m = 0.032;
  file.drive = {67.0, -0.52};
  file.method = "algorithm1";
  file.coil_sets = {{{61.34, -0.54}, {-0.785, 0.785}, {0.9, 0.8}, {1.5, 1.6}, {}},
                    {{61.62, -0.55}, {-0.785, 0.785}, {0.91, 0.81}, {1.4, 1.7}, {}}};
  file.data_sha256 = "ff";
  const std::string text = format_calibration_file(file);
  const CalibrationFile parsed = parse_calibration_file(yaml::Node::load_string(text, "calib.yaml"));
  REQUIRE(parsed.coil_sets.size() == 2);
  CHECK(parsed.coil_sets[1].estimate.motor_constant_N_per_A == 61.62);
  CHECK(parsed.coil_sets[0].gain_ratio[1] == 0.8);
  CHECK(format_calibration_file(parsed) == text);
  CHECK_FALSE(parsed.coil_sets[0].quality.has_value());  // a file without fit_quality reads as before
  // With the fit quality, every figure comes back exactly.
  CalibrationFile with_quality = file;
  with_quality.coil_sets[1].quality = CalibrationQuality{{0.0012, 0.0031}, 1.0000000000000002, {1.7, 2.25}};
  const std::string quality_text = format_calibration_file(with_quality);
  const CalibrationFile quality_parsed = parse_calibration_file(yaml::Node::load_string(quality_text, "calib.yaml"));
  REQUIRE(quality_parsed.coil_sets[1].quality.has_value());
  CHECK(quality_parsed.coil_sets[1].quality->gain_ratio_standard_error[1] == 0.0031);
  CHECK(quality_parsed.coil_sets[1].quality->separation_condition == 1.0000000000000002);
  CHECK(quality_parsed.coil_sets[1].quality->offset_inflation[1] == 2.25);
  CHECK_FALSE(quality_parsed.coil_sets[0].quality.has_value());
  CHECK(format_calibration_file(quality_parsed) == quality_text);
  std::string negative = quality_text;
  negative.replace(negative.find("2.25"), 4, "-2.5");
  CHECK_THROWS_WITH(parse_calibration_file(yaml::Node::load_string(negative, "calib.yaml")),
                    Catch::Contains("offset_inflation") && Catch::Contains(">= 0"));
  std::string broken = text;
  broken.replace(broken.find("coil_sets: 2"), 12, "coil_sets: 3");
  CHECK_THROWS_WITH(parse_calibration_file(yaml::Node::load_string(broken, "calib.yaml")),
                    Catch::Contains("calib.yaml") && Catch::Contains("coil_sets"));
}

TEST_CASE("the encoder reference round-trips, is absent for an absolute encoder, and compares frames",
          "[model_file]") {
  CalibrationFile file;
  file.pole_pitch_m = 0.03;
  file.drive = {67.0, -0.52};
  file.method = "algorithm1";
  file.coil_sets = {{{61.34, -0.54}, {-0.785, 0.785}, {0.9, 0.8}, {1.5, 1.6}, {}}};
  // An absolute encoder's file has no encoder_reference: what every file before homing was.
  const std::string absolute = format_calibration_file(file);
  CHECK(absolute.find("encoder_reference") == std::string::npos);
  CHECK(parse_calibration_file(yaml::Node::load_string(absolute, "c.yaml")).reference.method == "none");
  file.reference = {"index", -0.0125};
  const std::string text = format_calibration_file(file);
  const CalibrationFile parsed = parse_calibration_file(yaml::Node::load_string(text, "c.yaml"));
  CHECK(parsed.reference.method == "index");
  CHECK(parsed.reference.position_m == -0.0125);
  CHECK(format_calibration_file(parsed) == text);
  // Model files the same way.
  std::mt19937_64 rng(7);
  ModelFile model = random_model_file(ModelKind::kSpline, 2, rng);
  model.reference = {"reference_switch", 0.04};
  const ModelFile model_parsed = parse_model_file(yaml::Node::load_string(format_model_file(model), "m.yaml"));
  CHECK(model_parsed.reference.method == "reference_switch");
  CHECK(model_parsed.reference.position_m == 0.04);
  // The same frame: the same method, and for a homed one the same position within 1 nm.
  CHECK(EncoderReference{"index", 0.0}.same_frame({"index", 0.5e-9}));
  CHECK_FALSE(EncoderReference{"index", 0.0}.same_frame({"index", 2e-9}));
  CHECK_FALSE(EncoderReference{"index", 0.0}.same_frame({"reference_switch", 0.0}));
  CHECK(EncoderReference{"none", 0.0}.same_frame({"none", 3.0}));
  CHECK_FALSE(EncoderReference{"none", 0.0}.same_frame({"index", 0.0}));
  std::string unknown = text;
  unknown.replace(unknown.find("method: index"), 13, "method: laser");
  CHECK_THROWS_WITH(parse_calibration_file(yaml::Node::load_string(unknown, "c.yaml")),
                    Catch::Contains("c.yaml") && Catch::Contains("laser"));
}
