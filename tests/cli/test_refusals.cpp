// The bad-input contract of `clm calibrate`, `identify`, `ff-identify` and
// `commutate`, checked on the real binary: a non-zero exit status, exactly one
// line on stderr naming the file, the line and the column, and nothing written
// (no output, no temporary file, an existing output left byte for byte).
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <random>

#include "cli/cli_support.hpp"
#include "support/ideal_plant.hpp"
#include "commutation/model_file.hpp"
#include "support/random_model.hpp"
#include "tools/data/csv_table.hpp"

using namespace clm;
using namespace clm::cli_test;
using clm::data::shortest_double;
namespace fs = std::filesystem;

namespace {

const std::string kMotor = source_path("config/motor-sim.yaml");
const std::string kMotor2Coil = source_path("config/motor-sim-2coil.yaml");

/// Runs `args` (args[0] is the subcommand) twice, without and with an
/// existing `output`, and checks the refusal: status ≠ 0, stderr exactly
/// "clm <subcommand>: error: <expected>", the directory of `output` unchanged.
void check_refused(const std::vector<std::string>& args, const std::string& output, const std::string& expected) {
  const std::string directory = fs::path(output).parent_path().string();
  const std::string output_name = fs::path(output).filename().string();
  fs::remove(output);
  const auto before = listing(directory);
  std::string command = "clm";
  for (const auto& a : args) command += " " + a;
  INFO(command);
  {
    const ProcessResult result = run_clm(args);
    INFO("stderr: " << result.err);
    CHECK(result.exit_code != 0);
    const auto lines = result.err_lines();
    REQUIRE(lines.size() == 1);
    CHECK(lines[0] == "clm " + args[0] + ": error: " + expected);
    CHECK(listing(directory) == before);  // no output and no temporary file
  }
  const std::string previous = "an output of an earlier run\n";
  write_file(output, previous);
  const ProcessResult again = run_clm(args);
  INFO("stderr: " << again.err);
  CHECK(again.exit_code != 0);
  CHECK(again.err_lines().size() == 1);
  CHECK(read_file(output) == previous);
  auto with_output = before;
  with_output.insert(output_name);
  CHECK(listing(directory) == with_output);
  fs::remove(output);
}

/// The argument after --output.
std::string output_of(const std::vector<std::string>& args) {
  const auto at = std::find(args.begin(), args.end(), "--output");
  REQUIRE(at + 1 < args.end());
  return *(at + 1);
}

/// calibrate and identify on `data` with `motor`, each writing into the data's directory.
std::vector<std::vector<std::string>> experiment_commands(const TemporaryDirectory& dir, const std::string& data,
                                                          const std::string& motor) {
  return {{"calibrate", "--motor", motor, "--data", data, "--output", dir.file("calibration.yaml")},
          {"identify", "--motor", motor, "--data", data, "--output", dir.file("model.yaml"), "--restarts", "1"}};
}

void check_experiment_data_refused(const CsvLines& lines, const std::string& motor, const std::string& expected) {
  TemporaryDirectory dir;
  const std::string data = dir.file("data.csv");
  write_file(data, join_lines(lines));
  for (const auto& args : experiment_commands(dir, data, motor)) check_refused(args, output_of(args), data + expected);
}

/// The file's line (1-based) holding `text`.
std::size_t line_of(const std::string& file_text, const std::string& text) {
  const std::size_t at = file_text.find(text);
  REQUIRE(at != std::string::npos);
  return 1 + static_cast<std::size_t>(std::count(file_text.begin(), file_text.begin() + static_cast<long>(at), '\n'));
}

std::string insert_after_line(const std::string& text, const std::string& line, const std::string& inserted) {
  const std::size_t at = text.find(line);
  REQUIRE(at != std::string::npos);
  const std::size_t end = text.find('\n', at) + 1;
  return text.substr(0, end) + inserted + text.substr(end);
}

std::string erase_line(const std::string& text, const std::string& line) {
  const std::size_t at = text.find(line);
  REQUIRE(at != std::string::npos);
  return text.substr(0, at) + text.substr(text.find('\n', at) + 1);
}

CalibrationFile calibration_for(int coil_sets, double pole_pitch_m) {
  CalibrationFile file;
  file.pole_pitch_m = pole_pitch_m;
  file.drive = {67.0, -0.52};
  file.method = "algorithm1";
  for (int l = 0; l < coil_sets; ++l) {
    CalibrationFile::CoilSet c;
    c.estimate = {61.0 - l, -0.54};
    c.delta_rad = {-kPi / 4, kPi / 4};
    c.gain_ratio = {0.9, 0.9};
    c.residual_rms_N = {1.0, 1.0};
    file.coil_sets.push_back(c);
  }
  return file;
}

std::string spline_model_for(int coil_sets, double pole_pitch_m, unsigned seed) {
  std::mt19937_64 rng(seed);
  ModelFile file;
  file.model = test::random_spline_model(coil_sets, pole_pitch_m, rng);
  return format_model_file(file);
}

CsvLines desired_force_lines() {
  CsvLines lines = {"y_m,Fy_N,Fx_N,Tz_Nm"};
  for (int k = 0; k < 20; ++k) {
    lines.push_back(shortest_double(-0.05 + 0.005 * k) + "," + shortest_double(10.0 * k - 90.0) + ",0.5,-0.2");
  }
  return lines;
}

}  // namespace

TEST_CASE("calibrate and identify refuse a missing column naming the file, line 1 and the column", "[cli]") {
  for (const char* column : {"t_s", "coil_set", "delta_rad", "magnitude_N", "y_m"}) {
    auto lines = synthetic_experiment_lines(3);
    drop_column(lines, column);
    check_experiment_data_refused(lines, kMotor, std::string(":1: missing column '") + column + "'");
  }
  // The force columns go together: one or two of them missing is refused
  // (all three missing is data without a force sensor).
  for (const char* column : {"Fy_N", "Fx_N", "Tz_Nm"}) {
    auto lines = synthetic_experiment_lines(3);
    drop_column(lines, column);
    check_experiment_data_refused(lines, kMotor,
                                  std::string(":1: missing column '") + column +
                                      "': the force columns Fy_N, Fx_N and Tz_Nm go together (all, or none without "
                                      "a force sensor)");
  }
}

TEST_CASE("calibrate and identify refuse a NaN, infinite, empty or non-numeric cell naming file, line and column",
          "[cli]") {
  struct Case {
    std::size_t line;
    const char* column;
    const char* text;
  };
  for (const Case& c : {Case{5, "Fy_N", "nan"}, Case{9, "y_m", "inf"}, Case{30, "Tz_Nm", ""},
                        Case{49, "magnitude_N", "-nan"}, Case{12, "Fx_N", "0x1p3"}, Case{2, "t_s", "1e999"}}) {
    auto lines = synthetic_experiment_lines(3);
    set_cell(lines, c.line, c.column, c.text);
    check_experiment_data_refused(lines, kMotor,
                                  ":" + std::to_string(c.line) + ": column '" + c.column + "': '" + c.text +
                                      "' is not a finite number");
  }
  // A stray comma: the row has one cell more than the header.
  auto lines = synthetic_experiment_lines(3);
  lines[20 - 1] += ",5";
  check_experiment_data_refused(lines, kMotor, ":20: 9 cells, the header has 8");
}

TEST_CASE("calibrate and identify refuse a coil_set outside 1..L naming the line", "[cli]") {
  for (const auto& [line, value] : {std::pair<std::size_t, std::string>{7, "4"}, {3, "0"}, {40, "-1"}, {4, "1.5"}}) {
    auto lines = synthetic_experiment_lines(3);
    set_cell(lines, line, "coil_set", value);
    check_experiment_data_refused(lines, kMotor,
                                  ":" + std::to_string(line) + ": column 'coil_set': value " + value +
                                      " is not a coil set of this motor (1..3)");
  }
}

TEST_CASE("calibrate and identify refuse a coil set with a single phase offset, or with three", "[cli]") {
  // Coil set 2 occupies lines 18..33 (8 rows at -pi/4, then 8 at +pi/4).
  auto single = synthetic_experiment_lines(3);
  for (std::size_t line = 26; line <= 33; ++line) set_cell(single, line, "delta_rad", shortest_double(-kPi / 4));
  check_experiment_data_refused(single, kMotor,
                                ": column 'delta_rad': coil set 2 has a single phase offset (" +
                                    shortest_double(-kPi / 4) +
                                    " rad); calibration and identification need two distinct offsets");
  auto three = synthetic_experiment_lines(3);
  set_cell(three, 14, "delta_rad", "0.5");
  check_experiment_data_refused(three, kMotor,
                                ":14: column 'delta_rad': coil set 1 has a third phase offset 0.5 rad; each coil set "
                                "needs exactly two");
}

TEST_CASE("calibrate and identify refuse data of another motor: two-coil data with motor-sim.yaml and the reverse",
          "[cli]") {
  check_experiment_data_refused(synthetic_experiment_lines(2), kMotor,
                                ": column 'coil_set': no rows for coil set 3 (the motor has 3)");
  // The first row of coil set 3 is line 2 + 2 * 16.
  check_experiment_data_refused(synthetic_experiment_lines(3), kMotor2Coil,
                                ":34: column 'coil_set': value 3 is not a coil set of this motor (1..2)");
}

TEST_CASE("calibrate, identify and commutate refuse unknown and missing keys of the motor file with the line", "[cli]") {
  TemporaryDirectory dir;
  const std::string data = dir.file("data.csv");
  write_file(data, join_lines(synthetic_experiment_lines(3)));
  const std::string calibration = dir.file("calibration-in.yaml");
  write_file(calibration, format_calibration_file(calibration_for(3, 0.03)));
  const std::string input = dir.file("forces.csv");
  write_file(input, join_lines(desired_force_lines()));
  const std::string motor = dir.file("motor.yaml");
  const std::string original = read_file(clm::test::ideal_plant_file("motor-sim.yaml"));  // without its plant terms

  struct Variant {
    std::string text;
    std::string expected;  // after "motor.yaml:"
  };
  std::vector<Variant> variants;
  {
    const std::string text = insert_after_line(original, "  coil_sets: 3", "  coil_set: 3\n");
    variants.push_back({text, std::to_string(line_of(text, "  coil_set: 3\n")) + ": motor.coil_set: unknown key 'coil_set'; did you mean 'coil_sets'?"});
  }
  {
    const std::string text = erase_line(original, "  coil_sets: 3");
    variants.push_back({text, std::to_string(line_of(text, "  pole_pitch_m")) + ": motor: missing key 'coil_sets'"});
  }
  {
    const std::string text = insert_after_line(original, "    phase_offset_rad:", "    phase_offset_deg: -30\n");
    variants.push_back({text, std::to_string(line_of(text, "    phase_offset_deg")) +
                                  ": drive.commutation.phase_offset_deg: unknown key 'phase_offset_deg'; did you mean "
                                 "'phase_offset_rad'?"});
  }
  {
    const std::string text = erase_line(original, "    motor_constant_N_per_A: 67.0");
    variants.push_back({text, std::to_string(line_of(text, "    phase_offset_rad")) +
                                  ": drive.commutation: missing key 'motor_constant_N_per_A'"});
  }
  {
    const std::string text = erase_line(erase_line(erase_line(erase_line(erase_line(original, "motor:"),
                                                                          "  pole_pitch_m"),
                                                               "  coil_sets"),
                                                    "  stroke_min_m"),
                                         "  stroke_max_m");
    variants.push_back({text, std::to_string(line_of(text, "drive:")) + ": (top level): missing key 'motor'"});
  }
  for (const auto& variant : variants) {
    write_file(motor, variant.text);
    auto commands = experiment_commands(dir, data, motor);
    commands.push_back({"commutate", "--motor", motor, "--calibration", calibration, "--input", input, "--output",
                        dir.file("setpoints.csv")});
    for (const auto& args : commands) check_refused(args, output_of(args), motor + ":" + variant.expected);
  }
}

TEST_CASE("ff-identify refuses a missing column, a NaN cell and time that does not increase, with the line", "[cli]") {
  TemporaryDirectory dir;
  const std::string data = dir.file("closed-loop.csv");
  const std::string output = dir.file("feedforward.yaml");
  const std::vector<std::string> args = {"ff-identify", "--data", data, "--output", output};
  for (const char* column : {"t_s", "r_m", "F_star_N"}) {
    auto lines = synthetic_feedforward_lines();
    drop_column(lines, column);
    write_file(data, join_lines(lines));
    check_refused(args, output, data + ":1: missing column '" + column + "'");
  }
  auto nan = synthetic_feedforward_lines();
  set_cell(nan, 10, "F_star_N", "nan");
  write_file(data, join_lines(nan));
  check_refused(args, output, data + ":10: column 'F_star_N': 'nan' is not a finite number");
  auto backwards = synthetic_feedforward_lines();
  set_cell(backwards, 12, "t_s", "0.009");  // line 11 holds t = 0.009 s
  write_file(data, join_lines(backwards));
  check_refused(args, output, data + ":12: column 't_s': time does not increase");
}

TEST_CASE("commutate refuses a missing column and a NaN cell of the desired forces, with the line", "[cli]") {
  TemporaryDirectory dir;
  const std::string calibration = dir.file("calibration.yaml");
  write_file(calibration, format_calibration_file(calibration_for(3, 0.03)));
  const std::string input = dir.file("forces.csv");
  const std::string output = dir.file("setpoints.csv");
  const std::vector<std::string> args = {"commutate", "--motor", kMotor, "--calibration", calibration,
                                         "--input", input, "--output", output};
  for (const char* column : {"y_m", "Fy_N", "Fx_N", "Tz_Nm"}) {
    auto lines = desired_force_lines();
    drop_column(lines, column);
    write_file(input, join_lines(lines));
    check_refused(args, output, input + ":1: missing column '" + column + "'");
  }
  auto nan = desired_force_lines();
  set_cell(nan, 4, "Fx_N", "nan");
  write_file(input, join_lines(nan));
  check_refused(args, output, input + ":4: column 'Fx_N': 'nan' is not a finite number");
}

TEST_CASE("commutate refuses a model or calibration made for another motor, naming both files", "[cli]") {
  TemporaryDirectory dir;
  const std::string input = dir.file("forces.csv");
  write_file(input, join_lines(desired_force_lines()));
  const std::string output = dir.file("setpoints.csv");
  const auto commutate = [&](const std::string& motor, const char* option, const std::string& file) {
    return std::vector<std::string>{"commutate", "--motor", motor, option, file, "--input", input, "--output", output};
  };
  // Made for config/motor-sim-2coil.yaml (2 coil sets, 24 mm), used with config/motor-sim.yaml (3, 30 mm).
  const std::string model2 = dir.file("model-2coil.yaml");
  write_file(model2, spline_model_for(2, 0.024, 1));
  check_refused(commutate(kMotor, "--model", model2), output,
                model2 + ": motor.coil_sets: model has 2 coil sets, " + kMotor + " has 3");
  const std::string calibration2 = dir.file("calibration-2coil.yaml");
  write_file(calibration2, format_calibration_file(calibration_for(2, 0.024)));
  check_refused(commutate(kMotor, "--calibration", calibration2), output,
                calibration2 + ": motor.coil_sets: calibration has 2 coil sets, " + kMotor + " has 3");
  // And the reverse, and a pole pitch that differs alone.
  const std::string model3 = dir.file("model-3coil.yaml");
  write_file(model3, spline_model_for(3, 0.03, 2));
  check_refused(commutate(kMotor2Coil, "--model", model3), output,
                model3 + ": motor.coil_sets: model has 3 coil sets, " + kMotor2Coil + " has 2");
  const std::string model_pitch = dir.file("model-pitch.yaml");
  write_file(model_pitch, spline_model_for(3, 0.024, 3));
  check_refused(commutate(kMotor, "--model", model_pitch), output,
                model_pitch + ": motor.pole_pitch_m: model has 0.024 m, " + kMotor + " has 0.03 m");
  const std::string calibration_pitch = dir.file("calibration-pitch.yaml");
  write_file(calibration_pitch, format_calibration_file(calibration_for(3, 0.024)));
  check_refused(commutate(kMotor, "--calibration", calibration_pitch), output,
                calibration_pitch + ": motor.pole_pitch_m: calibration has 0.024 m, " + kMotor + " has 0.03 m");
}

TEST_CASE("calibrate, identify, ff-identify and commutate answer --help with status 0 and their options", "[cli]") {
  for (const auto& [subcommand, option] : {std::pair<std::string, std::string>{"calibrate", "--data"},
                                           {"identify", "--model"},
                                           {"ff-identify", "--data"},
                                           {"commutate", "--calibration"}}) {
    const ProcessResult result = run_clm({subcommand, "--help"});
    INFO(subcommand << ": " << result.err);
    CHECK(result.exit_code == 0);
    CHECK(result.out.find("Usage:") != std::string::npos);
    CHECK(result.out.find(option) != std::string::npos);
    CHECK(result.out.find("--output") != std::string::npos);
    CHECK(result.err.empty());
  }
}

TEST_CASE("a bad command line (a missing option, a --data that does not exist) is refused in one line", "[cli]") {
  TemporaryDirectory dir;
  const std::string data = dir.file("data.csv");
  write_file(data, join_lines(synthetic_experiment_lines(3)));
  const std::string missing = dir.file("missing.csv");
  const std::string output = dir.file("calibration.yaml");
  check_refused({"calibrate", "--motor", kMotor, "--data", missing, "--output", output}, output,
                "--data: File does not exist: " + missing);
  const auto before = listing(dir.path());
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"calibrate", "--motor", kMotor, "--data", data},
        std::vector<std::string>{"identify", "--data", data, "--output", output},
        std::vector<std::string>{"ff-identify", "--output", output},
        std::vector<std::string>{"commutate", "--motor", kMotor, "--input", data, "--output", output, "--power", "x"}}) {
    const ProcessResult result = run_clm(args);
    INFO(args[0] << ": " << result.err);
    CHECK(result.exit_code != 0);
    REQUIRE(result.err_lines().size() == 1);
    CHECK(result.err_lines()[0].rfind("clm " + args[0] + ": error: ", 0) == 0);
    CHECK(listing(dir.path()) == before);
  }
}

TEST_CASE("commission refuses a configuration without a force sensor before it writes or moves anything",
          "[cli][force_sensor]") {
  TemporaryDirectory temporary("clm-commission-no-sensor");
  const fs::path dir = temporary.path();
  std::string text = read_file(source_path("config/servod.yaml"));
  const auto at = text.find("  force_sensor_node_id:");
  REQUIRE(at != std::string::npos);
  text.erase(at, text.find('\n', at) + 1 - at);
  const std::string relative = "motor_file: motor-sim.yaml";
  text.replace(text.find(relative), relative.size(), "motor_file: " + kMotor);
  write_file((dir / "servod.yaml").string(), text);
  const std::string out = (dir / "out").string();
  const ProcessResult result = run_clm({"commission", "--config", (dir / "servod.yaml").string(), "--out", out});
  INFO("stderr: " << result.err);
  CHECK(result.exit_code == 2);
  const auto lines = result.err_lines();
  REQUIRE(lines.size() == 1);
  CHECK(lines[0].find("can.force_sensor_node_id: absent") != std::string::npos);
  CHECK_FALSE(fs::exists(out));
}

TEST_CASE("commission --live refuses an --out the daemon may not load from before it contacts the daemon", "[cli]") {
  TemporaryDirectory dir;  // outside config/servod.yaml's file directories (its own)
  const std::string out = dir.file("commissioning");
  // A port no daemon listens on: were the directory checked only when the
  // daemon is asked to load, the run would end with "no CLM_SERVO_STATUS" instead.
  const ProcessResult result = run_clm({"commission", "--live", "--config", source_path("config/servod.yaml"), "--out",
                                        out, "--lcm-url", "udpm://239.255.76.67:7699?ttl=0", "--no-plots"});
  INFO("stderr: " << result.err);
  CHECK(result.exit_code == 2);
  const auto lines = result.err_lines();
  REQUIRE(lines.size() == 1);
  // The preflight's one line (tools/commission/preflight.hpp), with this one refusal.
  CHECK(lines[0].find("clm commission: error: live commissioning refused before the first experiment (1 problem): "
                      "1) --out '" + out + "'") == 0);
  CHECK(lines[0].find("is outside the directories the daemon may load from (" +
                      std::filesystem::canonical(source_path("config")).string() + ", its commands.file_directories)") !=
        std::string::npos);
  CHECK(lines[0].find("choose --out inside one of them") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(out));
}
