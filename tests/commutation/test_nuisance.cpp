// Nuisance terms of identification (docs/commutation.md, "Nuisance terms"):
// differentiation of sampled positions, the sensor offset from the mechanics
// and the direction-dependent force beside the PGNN and the spline model,
// each against a truth the test builds itself.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <random>
#include <utility>

#include "commutation/classical.hpp"
#include "commutation/identification/nuisance.hpp"
#include "commutation/identification/pgnn_training.hpp"
#include "commutation/identification/physics_fit.hpp"
#include "commutation/identification/report.hpp"
#include "commutation/identification/spline_fit.hpp"
#include "support/random_model.hpp"

using namespace clm;
using namespace clm::identification;

TEST_CASE("differentiate is exact for quadratics inside a stretch and restarts at a gap", "[nuisance]") {
  // Two stretches of 1 ms samples with 0.5 s between them; y = 3t² − 2t.
  Eigen::VectorXd t(12), y(12);
  for (int k = 0; k < 12; ++k) {
    t[k] = k < 6 ? 1e-3 * k : 0.5 + 1e-3 * k;
    y[k] = 3.0 * t[k] * t[k] - 2.0 * t[k];
  }
  const Eigen::VectorXd v = differentiate(t, y);
  for (int k : {1, 2, 3, 4, 7, 8, 9, 10}) CHECK(v[k] == Approx(6.0 * t[k] - 2.0).epsilon(1e-9));
  // One-sided at the ends of each stretch: off by 3·dt, never across the gap.
  for (int k : {0, 5, 6, 11}) CHECK(std::abs(v[k] - (6.0 * t[k] - 2.0)) <= 3.0 * 1e-3 + 1e-12);
  Eigen::VectorXd lone_t(5), lone_y(5);
  lone_t << 0.0, 1.0, 1.001, 1.002, 1.003;
  lone_y << 5.0, 7.0, 7.002, 7.004, 7.006;
  CHECK(differentiate(lone_t, lone_y)[0] == 0.0);  // a stretch of one sample
  CHECK_THROWS_AS(differentiate(lone_t, Eigen::VectorXd::Zero(2)), std::invalid_argument);
}

TEST_CASE("the sensor offset and the mechanics come back from positions and the measured force", "[nuisance]") {
  // Independent truth: a few lines of mechanics with known mass, friction and
  // offset; positions quantised like a 0.1 µm encoder at 1 kHz.
  const double mass_kg = 12.0, viscous = 35.0, coulomb = 9.0, smoothing = 1e-3, offset_N = 0.4;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0.0, 0.8);
  std::vector<MotionRecord> records;
  for (int run = 0; run < 2; ++run) {
    const int n = 20000;
    MotionRecord record;
    record.time_s.resize(n);
    record.position_m.resize(n);
    record.force_N.resize(n);
    // Strokes of ±0.1 m along the minimum-jerk profile s(τ) = 10τ³ − 15τ⁴ + 6τ⁵,
    // each followed by a dwell; two stroke times, so two speeds.
    const double stroke_s = run == 0 ? 1.0 : 0.4, dwell_s = 0.3;
    for (int k = 0; k < n; ++k) {
      const double t = 1e-3 * k;
      const double period = stroke_s + dwell_s;
      const int stroke = static_cast<int>(t / period);
      const double tau = std::min(1.0, (t - stroke * period) / stroke_s);
      const double from = stroke % 2 == 0 ? -0.1 : 0.1;
      const double span = -2.0 * from;
      const double y = from + span * (10 * std::pow(tau, 3) - 15 * std::pow(tau, 4) + 6 * std::pow(tau, 5));
      const double v = tau < 1.0 ? span / stroke_s * (30 * tau * tau - 60 * std::pow(tau, 3) + 30 * std::pow(tau, 4)) : 0.0;
      const double a = tau < 1.0 ? span / (stroke_s * stroke_s) * (60 * tau - 180 * tau * tau + 120 * std::pow(tau, 3)) : 0.0;
      record.time_s[k] = t + 100.0 * run;
      record.position_m[k] = 1e-7 * std::round(y / 1e-7);
      record.force_N[k] = mass_kg * a + viscous * v + coulomb * std::tanh(v / smoothing) + offset_N + noise(rng);
    }
    records.push_back(record);
  }
  const DrivingOffsetFit fit = fit_driving_sensor_offset(records);
  CHECK(fit.offset_N == Approx(offset_N).margin(0.03));
  CHECK(fit.mass_kg == Approx(mass_kg).epsilon(0.03));
  CHECK(fit.viscous_N_s_per_m == Approx(viscous).epsilon(0.05));
  CHECK(fit.coulomb_N == Approx(coulomb).epsilon(0.05));
  CHECK(fit.samples == 40000);
  // Standing still only: nothing separates mass and friction from the offset.
  std::vector<MotionRecord> still{{Eigen::VectorXd::LinSpaced(100, 0.0, 0.099), Eigen::VectorXd::Zero(100),
                                   Eigen::VectorXd::Constant(100, 0.4)}};
  CHECK_THROWS_AS(fit_driving_sensor_offset(still), std::invalid_argument);
}

namespace {

constexpr double kPolePitch = 0.032;
const DriveCommutation kDrive{67.0, -0.52};
const Wrench kDirectionForce(-1.5, 0.2, 0.1);
constexpr double kSmoothing_m_per_s = 0.002;

// Coil set 0 of `truth` driven alone with offsets ±π/4 on sweeps whose force
// demand varies independently of the direction of motion, plus the
// direction-dependent force C·tanh(ẏ/v_c) and noise.
CoilSetDataset data_with_direction_force(const ElectromagneticModel& truth, std::mt19937_64& rng) {
  std::normal_distribution<double> noise(0.0, 0.3);
  const int per_group = 6000;
  CoilSetDataset data;
  data.position_m.resize(2 * per_group);
  data.velocity_m_per_s.resize(2 * per_group);
  data.currents_A.resize(2, 2 * per_group);
  data.wrench.resize(3, 2 * per_group);
  data.group.resize(2 * per_group);
  for (int g = 0; g < 2; ++g) {
    for (int k = 0; k < per_group; ++k) {
      const int t = g * per_group + k;
      const double phase = 2.0 * kPi * 3.0 * k / per_group + 0.3 * g;
      const double y = 0.1 * std::sin(phase);
      const double v = 0.3 * std::cos(phase);
      const double magnitude = 40.0 * std::cos(1.7 * phase) + 15.0 * std::sin(0.37 * phase) + 5.0;
      const Eigen::Vector2d i = drive_phase_currents(kDrive, {magnitude, g == 0 ? -kPi / 4 : kPi / 4}, y, kPolePitch);
      CoilGain gain;
      Wrench cogging;
      truth.evaluate_coil_set(0, y, gain, cogging);
      data.position_m[t] = y;
      data.velocity_m_per_s[t] = v;
      data.currents_A.col(t) = i;
      data.wrench.col(t) = gain * i + cogging + kDirectionForce * std::tanh(v / kSmoothing_m_per_s) +
                           Wrench(noise(rng), noise(rng), 0.1 * noise(rng));
      data.group[static_cast<std::size_t>(t)] = g;
    }
  }
  return data;
}

// RMS over a position grid of the model's K̂·i + F̂_cog against the truth's,
// for a unit current vector: how far the static model is from the truth.
double static_error(const ElectromagneticModel& truth, const ElectromagneticModel& model) {
  double sum = 0.0;
  int count = 0;
  for (double y = -0.095; y <= 0.095; y += 0.001) {
    CoilGain true_gain, gain;
    Wrench true_cogging, cogging;
    truth.evaluate_coil_set(0, y, true_gain, true_cogging);
    model.evaluate_coil_set(0, y, gain, cogging);
    const Eigen::Vector2d i(0.3, -0.2);
    sum += ((gain - true_gain) * i + cogging - true_cogging).squaredNorm();
    ++count;
  }
  return std::sqrt(sum / count);
}

// Training and validation data: 20 % held out in contiguous blocks.
std::pair<CoilSetDataset, CoilSetDataset> held_out(const CoilSetDataset& data) {
  const auto split = split_contiguous_blocks(data, 0.2);
  return {data.subset(split.training), data.subset(split.validation)};
}

}  // namespace

TEST_CASE("the spline fit identifies the direction-dependent force beside the model", "[nuisance]") {
  std::mt19937_64 rng(61);
  const auto truth = test::random_spline_model(1, kPolePitch, rng);
  const auto [training, validation] = held_out(data_with_direction_force(truth, rng));
  const auto basis = truth.spline_basis;
  const auto model_of = [&](const CoilSetModel& part) { return single_coil_set_model(ModelKind::kSpline, kPolePitch, {}, basis, part); };

  SplineOptions with;
  with.direction_smoothing_m_per_s = kSmoothing_m_per_s;
  IdentificationReport report;
  const auto identified = model_of(identify_spline_coil_set(training, validation, kPolePitch, basis, with, report));
  for (int q = 0; q < 3; ++q) CHECK(report.direction_force.amplitude[q] == Approx(kDirectionForce[q]).margin(0.03));
  CHECK(report.proposition_holds[0]);
  CHECK(report.proposition_holds[1]);
  CHECK(report.proposition_holds[2]);

  // Without the term the fit folds part of the force into K̂ and F̂_cog.
  IdentificationReport plain_report;
  const auto plain = model_of(identify_spline_coil_set(training, validation, kPolePitch, basis, {}, plain_report));
  CHECK(!plain_report.direction_force.identified());
  CHECK(static_error(truth, identified) < 0.5 * static_error(truth, plain));
}

TEST_CASE("the PGNN identifies the direction-dependent force beside the model", "[nuisance]") {
  std::mt19937_64 rng(62);
  const auto truth = test::random_pgnn_model(1, kPolePitch, rng);
  const auto [training, validation] = held_out(data_with_direction_force(truth, rng));
  PgnnOptions options;
  options.restarts = 2;
  options.restart_iterations = 20;
  options.final_iterations = 30;
  options.regularisation = 0.01;
  options.direction_smoothing_m_per_s = kSmoothing_m_per_s;
  IdentificationReport report;
  identify_pgnn_coil_set(training, validation, kPolePitch, truth.normalisation, options, report);
  for (int q = 0; q < 3; ++q) CHECK(report.direction_force.amplitude[q] == Approx(kDirectionForce[q]).margin(0.05));
  CHECK(report.refit_on_all_data);
  CHECK(report.proposition_holds[0]);
  CHECK(report.proposition_holds[1]);
  CHECK(report.proposition_holds[2]);
  // The physics-only fit carries its own term and a constant force.
  const PhysicsFit physics = fit_physics_only(training, kPolePitch, kSmoothing_m_per_s);
  CHECK(physics.direction.identified());
  CHECK(std::isfinite(physics.constant[0]));
}
