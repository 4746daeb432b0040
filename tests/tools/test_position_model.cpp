// Commissioning without a force sensor at the tools' level: experiment rows
// without force columns from a motor integrated in the test
// (tests/support/position_only_motor.hpp) identified from positions, then
// Algorithm 1 on the force that model reconstructs, against Algorithm 1 on
// the motor's own electromagnetic force of the same rows.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <sstream>

#include "commutation/calibration.hpp"
#include "commutation/classical.hpp"
#include "support/position_only_motor.hpp"
#include "support/random_model.hpp"
#include "tools/data/commissioning_steps.hpp"
#include "tools/data/csv_table.hpp"
#include "tools/data/position_model.hpp"

using namespace clm;
using namespace clm::data;
using test::PositionOnlyMotor;

namespace {

MotorDescription description() {
  MotorDescription motor;
  motor.pole_pitch_m = PositionOnlyMotor::kPolePitch_m;
  motor.coil_sets = 1;
  motor.stroke_min_m = -0.07;
  motor.stroke_max_m = 0.07;
  motor.drive = PositionOnlyMotor::nominal_drive();
  return motor;
}

// Two runs, one per offset, a second apart, as t_s, coil_set, delta_rad, magnitude_N, y_m.
std::string experiment_csv(const PositionOnlyMotor& motor) {
  std::ostringstream out;
  out.precision(17);
  out << "t_s,coil_set,delta_rad,magnitude_N,y_m\n";
  double offset_s = 0.0;
  for (const double delta : {-kPi / 4, kPi / 4}) {
    std::vector<double> magnitude;
    const auto run = motor.run(delta, 12.0, delta > 0 ? 1.0 : 0.0, &magnitude);
    for (Eigen::Index k = 0; k < run.position_m.size(); ++k) {
      out << offset_s + run.time_s[k] << ",1," << delta << "," << magnitude[static_cast<std::size_t>(k)] << ","
          << run.position_m[k] << "\n";
    }
    offset_s += run.time_s[run.time_s.size() - 1] + 1.0;
  }
  return out.str();
}

}  // namespace

TEST_CASE("from positions alone the tools find the motor's gains and Algorithm 1 its k and zeta", "[position]") {
  std::mt19937_64 rng(17);
  const PositionOnlyMotor truth(rng, 55.0, -0.45);
  const MotorDescription motor = description();
  ExperimentData data = read_experiment_data(CsvTable::parse(experiment_csv(truth), "position.csv"), motor);
  REQUIRE_FALSE(data.measured_forces);

  // The force-sensor steps refuse such data, saying why.
  CHECK_THROWS_WITH(calibrate_motor(data, motor, CalibrationMethod::kAlgorithm1),
                    Catch::Contains("no force columns"));
  std::vector<CoilSetIdentification> reports;
  CHECK_THROWS_WITH(identify_motor(data, motor, {}, reports), Catch::Contains("no force columns"));
  CHECK_THROWS_WITH(calibrate_motor(data, motor, CalibrationMethod::kPosition),
                    Catch::Contains("has not reconstructed it"));

  PositionIdentifyOptions options;
  options.motion.mass_kg = truth.mass_kg;
  const PositionIdentification identified = identify_from_position(data, motor, options);
  CHECK(identified.mass_given);
  CHECK(identified.mass_kg == truth.mass_kg);
  REQUIRE(identified.fits.size() == 1);
  CHECK(identified.fits[0].viscous_N_s_per_m == Approx(truth.viscous_N_s_per_m).epsilon(0.1));
  CHECK(identified.fits[0].direction_N == Approx(truth.direction_N).epsilon(0.1));
  // The y-row of the model file is the fit's; the gains within 0.5 N/A RMS of about 60.
  const ElectromagneticModel& model = identified.model.model;
  double square_sum = 0.0;
  int count = 0;
  for (double y = -0.05; y <= 0.05; y += 2.5e-4, ++count) {
    CoilGain gain;
    Wrench cogging;
    model.evaluate_coil_set(0, y, gain, cogging);
    square_sum += (gain.row(0) - truth.model.gain(y, truth.kPolePitch_m, truth.basis)).squaredNorm() / 2.0;
    CHECK(gain.bottomRows<2>().isZero());
  }
  CHECK(std::sqrt(square_sum / count) < 0.5);

  // Algorithm 1 on the reconstructed force, and on the motor's own force of the same rows.
  reconstruct_driving_force(data, motor, identified);
  const CalibrationFile calibration = calibrate_motor(data, motor, CalibrationMethod::kPosition);
  CHECK(calibration.method == "position");
  const CoilSetExperiment& experiment = data.coil_sets[0];
  std::array<std::vector<double>, 2> true_force;
  for (Eigen::Index k = 0; k < experiment.dataset.size(); ++k) {
    const auto& set = experiment.dataset;
    const double force_N = truth.model.gain(set.position_m[k], truth.kPolePitch_m, truth.basis).dot(set.currents_A.col(k));
    true_force[static_cast<std::size_t>(set.group[static_cast<std::size_t>(k)])].push_back(force_N);
  }
  const CalibrationResult expected = calibrate_classical(
      motor.drive.motor_constant_N_per_A, motor.drive.phase_offset_rad,
      {experiment.delta_rad[0], experiment.position_m[0], experiment.magnitude_N[0], true_force[0]},
      {experiment.delta_rad[1], experiment.position_m[1], experiment.magnitude_N[1], true_force[1]});
  const ClassicalEstimate& estimate = calibration.coil_sets[0].estimate;
  CHECK(estimate.motor_constant_N_per_A == Approx(expected.motor_constant_N_per_A).epsilon(0.01));
  CHECK(estimate.phase_offset_rad == Approx(expected.phase_offset_rad).margin(0.005));
}

TEST_CASE("a model is scored on the force sensor's held-out rows as the force models are", "[position]") {
  // Forces of a known spline model, made by the previous row's setpoint at
  // each row's position (the pairing), no noise, no sensor offset.
  std::mt19937_64 rng(23);
  const MotorDescription motor = description();
  ElectromagneticModel truth = test::random_spline_model(1, motor.pole_pitch_m, rng);
  std::ostringstream csv;
  csv.precision(17);
  csv << "t_s,coil_set,delta_rad,magnitude_N,y_m,Fy_N,Fx_N,Tz_Nm\n";
  for (const double delta : {-kPi / 4, kPi / 4}) {
    double previous_magnitude = 0.0;
    for (int k = 0; k < 2000; ++k) {
      const double t = (delta > 0 ? 10.0 : 0.0) + 1e-3 * k;
      const double y = 0.05 * std::sin(2.0 * t);
      const double magnitude = 40.0 * std::sin(7.0 * t);
      const Eigen::Vector2d i = drive_phase_currents(motor.drive, {previous_magnitude, delta}, y, motor.pole_pitch_m);
      CoilGain gain;
      Wrench cogging;
      truth.evaluate_coil_set(0, y, gain, cogging);
      csv << t << ",1," << delta << "," << magnitude << "," << y << "," << gain.row(0).dot(i) + cogging[0]
          << ",0,0\n";
      previous_magnitude = magnitude;
    }
  }
  const ExperimentData data = read_experiment_data(CsvTable::parse(csv.str(), "forces.csv"), motor);
  IdentifyOptions options;  // 20 % held out
  IdentifySummary summary;  // no nuisance terms: nothing removed or fitted beside the model
  summary.trials.emplace_back();
  std::vector<CoilSetIdentification> reports(1);
  reports[0].report.physics_validation[0] = 2.0;  // the physics-only fit's held-out F_y MSE [N²]
  // The truth scores 0; the truth with its cogging 0.5 N off scores 0.5²/2.
  CHECK(position_validation_score(data, options, summary, reports, truth) == Approx(0.0).margin(1e-18));
  ElectromagneticModel shifted = truth;
  shifted.coil_sets[0].cogging_spline.row(0).array() += 0.5;  // B-splines sum to one
  CHECK(position_validation_score(data, options, summary, reports, shifted) == Approx(0.125).epsilon(1e-9));
  // Nothing held out, nothing to score.
  options.validation_fraction = 0.0;
  CHECK(std::isnan(position_validation_score(data, options, summary, reports, truth)));
}

TEST_CASE("the model from positions that is scored never saw the held-out rows", "[position]") {
  std::mt19937_64 rng(29);
  const PositionOnlyMotor truth(rng, 55.0, -0.45);
  const MotorDescription motor = description();
  const std::string csv = experiment_csv(truth);
  const ExperimentData data = read_experiment_data(CsvTable::parse(csv, "position.csv"), motor);
  PositionIdentifyOptions options;
  options.motion.mass_kg = truth.mass_kg;
  const PositionIdentification identified = identify_from_position(data, motor, options);
  const auto coefficients = [](const ElectromagneticModel& model) {
    const CoilSetModel& c = model.coil_sets.at(0);
    Eigen::VectorXd all(c.column_a_spline.cols() * 3);
    all << c.column_a_spline.row(0).transpose(), c.column_b_spline.row(0).transpose(), c.cogging_spline.row(0).transpose();
    return all;
  };

  // Nothing excluded: the model kept.
  const Eigen::VectorXd kept = coefficients(identified.model.model);
  const Eigen::VectorXd none = coefficients(position_model_without(data, motor, options, identified, {{}}));
  INFO("nothing excluded: coefficients " << (none - kept).norm() << " off the model kept, of " << kept.norm());
  CHECK((none - kept).norm() < 1e-9 * kept.norm());

  // The force data's held-out rows: a fifth of them, in four stretches.
  const auto excluded = held_out_times(data, 0.2);
  REQUIRE(excluded.size() == 1);
  const double share = static_cast<double>(excluded[0].size()) / static_cast<double>(data.coil_sets[0].dataset.size());
  INFO("held-out share " << share);
  CHECK(share == Approx(0.2).margin(0.01));
  const Eigen::VectorXd without = coefficients(position_model_without(data, motor, options, identified, excluded));
  INFO("held out: coefficients " << (without - kept).norm() << " off the model kept");
  CHECK((without - kept).norm() > 1e-6 * kept.norm());  // a fit of its own

  // Those rows' positions and setpoints replaced by nonsense: the same model.
  std::istringstream in(csv);
  std::ostringstream corrupted;
  corrupted.precision(17);
  std::string line;
  std::getline(in, line);
  corrupted << line << "\n";
  std::size_t changed = 0;
  while (std::getline(in, line)) {
    double t, set, delta, magnitude, y;
    char c;
    std::istringstream row(line);
    row >> t >> c >> set >> c >> delta >> c >> magnitude >> c >> y;
    if (std::binary_search(excluded[0].begin(), excluded[0].end(), t)) {
      magnitude = -3.0 * magnitude + 7.0;
      y += 2e-3;
      ++changed;
    }
    corrupted << t << "," << set << "," << delta << "," << magnitude << "," << y << "\n";
  }
  REQUIRE(changed == excluded[0].size());
  const ExperimentData spoiled = read_experiment_data(CsvTable::parse(corrupted.str(), "spoiled.csv"), motor);
  const Eigen::VectorXd blind = coefficients(position_model_without(spoiled, motor, options, identified, excluded));
  INFO("held-out rows spoiled: coefficients " << (blind - without).norm() << " off, of " << without.norm());
  CHECK((blind - without).norm() < 1e-9 * without.norm());
}
