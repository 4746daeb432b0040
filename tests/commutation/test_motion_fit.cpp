// Position-based identification of the driving direction (no force
// sensor): a synthetic motor whose positions come from an independent
// integration of its mechanics written here (not the project's simulator),
// with known mass, friction, gains and cogging; the fit must recover them.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "commutation/classical.hpp"
#include "commutation/identification/motion_fit.hpp"

using namespace clm;
using namespace clm::identification;

namespace {

constexpr double kPolePitch = 0.03;
constexpr double kPeriod = 1e-3;
const DriveCommutation kDrive{60.0, -0.5};
const UniformCubicBasis kBasis{-0.07, 0.07, 28};  // 5 mm knots

struct Truth {
  double mass_kg = 12.0;
  double viscous = 30.0;
  double direction_N = 6.0;
  double smoothing_m_per_s = 1e-3;
  MotionFit model;  // the y-row on kBasis, the form the fit identifies

  double force_N(double y, const Eigen::Vector2d& i) const {
    return model.gain(y, kPolePitch, kBasis).dot(i.transpose()) + model.cogging_N(y, kBasis);
  }
};

Truth make_truth(std::mt19937_64& rng, bool nominal_physics) {
  std::uniform_real_distribution<double> gain(-3.0, 3.0), cogging(-2.0, 2.0);
  Truth truth;
  CoilGain a, b;
  classical_physics_parameters({nominal_physics ? kDrive.motor_constant_N_per_A : 55.0,
                                nominal_physics ? kDrive.phase_offset_rad : -0.45, 0.0, 0.0},
                               a, b);
  truth.model.a_y << a(0, 0), a(0, 1);
  truth.model.b_y << b(0, 0), b(0, 1);
  const int n = kBasis.size();
  truth.model.column_a = Eigen::RowVectorXd::NullaryExpr(n, [&] { return gain(rng); });
  truth.model.column_b = Eigen::RowVectorXd::NullaryExpr(n, [&] { return gain(rng); });
  truth.model.cogging = Eigen::RowVectorXd::NullaryExpr(n, [&] { return cogging(rng); });
  return truth;
}

/// One run: a PD loop with feedforward tracks two superposed sines with the
/// drive at offset `delta_rad`; the mechanics integrated in 20 substeps per
/// period, the setpoint held over the period after it is computed, the
/// currents commutated from the true position at every substep. Positions
/// quantised to 0.1 µm.
MotionRun run(const Truth& truth, double delta_rad, double seconds, double phase) {
  const auto samples = static_cast<Eigen::Index>(seconds / kPeriod);
  MotionRun out;
  out.time_s.resize(samples);
  out.position_m.resize(samples);
  out.currents_A.resize(2, samples);
  std::vector<double> magnitude(static_cast<std::size_t>(samples));
  double y = 0.0, v = 0.0, previous_measured = 0.0;
  const auto reference = [&](double t, int derivative) {
    const double w1 = 2.0 * kPi * 0.7, w2 = 2.0 * kPi * 2.3;
    const double a1 = 0.05, a2 = 0.006;
    const double s1 = std::pow(w1, derivative) * a1, s2 = std::pow(w2, derivative) * a2;
    const auto f = [&](double w, double p) {
      return derivative == 0 ? std::sin(w * t + p) : derivative == 1 ? std::cos(w * t + p) : -std::sin(w * t + p);
    };
    return s1 * f(w1, phase) + s2 * f(w2, 2.0 * phase);
  };
  for (Eigen::Index k = 0; k < samples; ++k) {
    const double t = k * kPeriod;
    const double measured = std::round(y / 1e-7) * 1e-7;
    out.time_s[k] = t;
    out.position_m[k] = measured;
    const double velocity = k > 0 ? (measured - previous_measured) / kPeriod : 0.0;
    previous_measured = measured;
    const double demand = 10.0 * reference(t, 2) + 2e5 * (reference(t, 0) - measured) + 2e3 * (reference(t, 1) - velocity);
    magnitude[static_cast<std::size_t>(k)] = demand;
    for (int step = 0; step < 20; ++step) {
      const Eigen::Vector2d i = drive_phase_currents(kDrive, {demand, delta_rad}, y, kPolePitch);
      const double force = truth.force_N(y, i) - truth.viscous * v -
                           truth.direction_N * std::tanh(v / truth.smoothing_m_per_s);
      v += force / truth.mass_kg * (kPeriod / 20);
      y += v * (kPeriod / 20);
    }
  }
  // What the tools give the fit: each setpoint's currents at the middle of its period.
  for (Eigen::Index k = 0; k < samples; ++k) {
    const double middle = k + 1 < samples ? 0.5 * (out.position_m[k] + out.position_m[k + 1]) : out.position_m[k];
    out.currents_A.col(k) = drive_phase_currents(kDrive, {magnitude[static_cast<std::size_t>(k)], delta_rad}, middle,
                                                 kPolePitch);
  }
  return out;
}

double rms_gain_error(const MotionFit& fit, const Truth& truth) {
  double sum = 0.0;
  int count = 0;
  for (double y = -0.05; y <= 0.05; y += 2.5e-4, ++count) {
    sum += (fit.gain(y, kPolePitch, kBasis) - truth.model.gain(y, kPolePitch, kBasis)).squaredNorm() / 2.0;
  }
  return std::sqrt(sum / count);
}

double rms_cogging_error(const MotionFit& fit, const Truth& truth) {
  double sum = 0.0;
  int count = 0;
  for (double y = -0.05; y <= 0.05; y += 2.5e-4, ++count) {
    const double e = fit.cogging_N(y, kBasis) - truth.model.cogging_N(y, kBasis);
    sum += e * e;
  }
  return std::sqrt(sum / count);
}

}  // namespace

TEST_CASE("mass, friction, gains and cogging come back from positions alone", "[motion-fit]") {
  std::mt19937_64 rng(11);
  for (const bool mass_known : {true, false}) {
    INFO((mass_known ? "mass given" : "mass identified, scale from the drive's nominal commutation"));
    // With the mass given, the truth's physics part differs from the
    // nominal one; without, the nominal commutation is the scale.
    const Truth truth = make_truth(rng, !mass_known);
    const std::vector<MotionRun> runs{run(truth, -kPi / 4, 12.0, 0.0), run(truth, kPi / 4, 12.0, 1.0)};
    MotionFitOptions options;
    options.drive = kDrive;
    options.mass_kg = mass_known ? truth.mass_kg : 0.0;
    const MotionFit fit = fit_driving_direction_from_motion(runs, kPolePitch, kBasis, options);
    INFO("mass " << fit.mass_kg << " f_v " << fit.viscous_N_s_per_m << " f_d " << fit.direction_N << " residual "
                 << fit.residual_rms_N << " N, gain error " << rms_gain_error(fit, truth) << " N/A, cogging error "
                 << rms_cogging_error(fit, truth) << " N");
    CHECK(fit.mass_kg == Approx(truth.mass_kg).epsilon(0.02));
    CHECK(fit.viscous_N_s_per_m == Approx(truth.viscous).epsilon(0.1));
    CHECK(fit.direction_N == Approx(truth.direction_N).epsilon(0.1));
    CHECK(rms_gain_error(fit, truth) < 0.5);     // of gains about 60 N/A
    CHECK(rms_cogging_error(fit, truth) < 0.3);  // of cogging about 1 N RMS
  }
}

TEST_CASE("the motion fit refuses runs of unequal steps and too few rows", "[motion-fit]") {
  MotionRun short_run;
  short_run.time_s = Eigen::VectorXd::LinSpaced(5, 0.0, 4e-3);
  short_run.position_m = Eigen::VectorXd::Zero(5);
  short_run.currents_A = Eigen::Matrix<double, 2, Eigen::Dynamic>::Zero(2, 5);
  MotionFitOptions options;
  options.drive = kDrive;
  CHECK_THROWS_AS(fit_driving_direction_from_motion({short_run}, kPolePitch, kBasis, options), std::invalid_argument);
  short_run.time_s[3] = 3.5e-3;
  CHECK_THROWS_AS(fit_driving_direction_from_motion({short_run}, kPolePitch, kBasis, options), std::invalid_argument);
}
