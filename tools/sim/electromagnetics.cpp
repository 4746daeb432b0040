#include "tools/sim/electromagnetics.hpp"

#include <algorithm>
#include <cmath>

#include "tools/sim/random.hpp"

namespace clm::sim {
namespace {

// Independent random streams of the truth (see stream_seed).
enum TruthStream : std::uint64_t {
  kStreamMagnetIntensity = 1,
  kStreamMagnetOrientation = 2,
  kStreamHarmonicPhases = 3,
  kStreamPhaseGains = 4,
  kStreamCoggingPhases = 5,
  kStreamCoggingSlow = 6,  // + axis
};

// Mean over a knot interval of Σ_k B_k(t)² for the uniform cubic B-spline:
// the variance of the spline with independent unit-variance coefficients,
// averaged over position (exactly 151/315).
constexpr double kMeanSplineVariance = 151.0 / 315.0;

struct Complex {
  double re;
  double im;
};
Complex multiply(Complex a, Complex b) { return {a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re}; }

}  // namespace

SmoothRandomFunction::SmoothRandomFunction(const SmoothVariation& variation, double track_start_m,
                                           double track_end_m, std::uint64_t seed)
    : slope_per_m_(variation.slope_per_m), centre_m_(0.5 * (track_start_m + track_end_m)) {
  if (variation.rms == 0.0) return;  // only the trend
  const double margin = variation.correlation_length_m;
  basis_.start_m = track_start_m - margin;
  basis_.end_m = track_end_m + margin;
  basis_.intervals =
      std::max(1, static_cast<int>(std::ceil((basis_.end_m - basis_.start_m) / variation.correlation_length_m)));
  RandomStream random(seed);
  const double scale = variation.rms / std::sqrt(kMeanSplineVariance);
  coefficients_.resize(static_cast<std::size_t>(basis_.size()));
  for (auto& coefficient : coefficients_) coefficient = scale * random.normal();
}

double SmoothRandomFunction::operator()(double track_position_m) const noexcept {
  double value = slope_per_m_ * (track_position_m - centre_m_);
  if (!coefficients_.empty()) {
    const auto span = basis_.evaluate(track_position_m);
    for (int k = 0; k < 4; ++k) value += span.value[k] * coefficients_[static_cast<std::size_t>(span.first + k)];
  }
  return value;
}

ElectromagneticTruth::ElectromagneticTruth(const ElectromagneticParameters& parameters, double travel_min_m,
                                           double travel_max_m)
    : parameters_(parameters), count_(parameters.coil_set_count()) {
  parameters_.validate();
  if (!(travel_max_m > travel_min_m)) {
    throw ParameterError("electromagnetic truth: travel_max_m must be above travel_min_m");
  }
  const std::uint64_t seed = parameters_.seed;

  // The coil sets see the track at y + d^l: cover every position they reach,
  // with the trend zero where the centre of the travel is.
  double lever_min = 0.0;
  double lever_max = 0.0;
  for (const auto& coil_set : parameters_.coil_sets) {
    lever_min = std::min(lever_min, coil_set.lever_arm_m);
    lever_max = std::max(lever_max, coil_set.lever_arm_m);
  }
  const double travel_centre = 0.5 * (travel_min_m + travel_max_m);
  const double track_start = travel_min_m + lever_min;
  const double track_end = travel_max_m + lever_max;
  // Shift the domain so that the function's centre is the travel centre.
  const double half = std::max(travel_centre - track_start, track_end - travel_centre);
  intensity_ = SmoothRandomFunction(parameters_.magnet_intensity, travel_centre - half, travel_centre + half,
                                    stream_seed(seed, kStreamMagnetIntensity));
  orientation_ = SmoothRandomFunction(parameters_.magnet_orientation_rad, travel_centre - half,
                                      travel_centre + half, stream_seed(seed, kStreamMagnetOrientation));

  RandomStream harmonic_phases(stream_seed(seed, kStreamHarmonicPhases));
  const double psi5 = kTwoPi * harmonic_phases.uniform();
  const double psi7 = kTwoPi * harmonic_phases.uniform();
  const double phase_shift[3] = {0.0, kTwoPiOverThree, -kTwoPiOverThree};
  for (int p = 0; p < 3; ++p) {
    const double angle5 = 5.0 * phase_shift[p] + psi5;
    const double angle7 = 7.0 * phase_shift[p] + psi7;
    fifth_rotation_[static_cast<std::size_t>(p)] = {std::cos(angle5), std::sin(angle5)};
    seventh_rotation_[static_cast<std::size_t>(p)] = {std::cos(angle7), std::sin(angle7)};
  }

  RandomStream phase_gains(stream_seed(seed, kStreamPhaseGains));
  for (auto& coil_set : phase_gain_) {
    for (auto& gain : coil_set) gain = 1.0 + parameters_.phase_gain_mismatch_rms * phase_gains.normal();
  }

  RandomStream cogging_phases(stream_seed(seed, kStreamCoggingPhases));
  for (const auto& harmonic : parameters_.cogging_periodic) {
    Wrench cos_part;
    Wrench sin_part;
    for (int q = 0; q < 3; ++q) {
      const double phase = kTwoPi * cogging_phases.uniform();
      cos_part[q] = harmonic.amplitude_N_N_Nm[q] * std::cos(phase);
      sin_part[q] = harmonic.amplitude_N_N_Nm[q] * std::sin(phase);
    }
    cogging_order_.push_back(harmonic.order);
    cogging_cos_.push_back(cos_part);
    cogging_sin_.push_back(sin_part);
    max_cogging_order_ = std::max(max_cogging_order_, harmonic.order);
  }
  for (int q = 0; q < 3; ++q) {
    const SmoothVariation slow{parameters_.cogging_slow_rms_N_N_Nm[q], parameters_.cogging_slow_correlation_length_m,
                               0.0};
    cogging_slow_[static_cast<std::size_t>(q)] = SmoothRandomFunction(
        slow, travel_min_m, travel_max_m, stream_seed(seed, kStreamCoggingSlow + static_cast<std::uint64_t>(q)));
  }
}

CoilGain ElectromagneticTruth::gain(int coil_set, double position_m) const noexcept {
  const auto l = static_cast<std::size_t>(coil_set);
  const CoilSetParameters& set = parameters_.coil_sets[l];
  const double track_position = position_m + set.lever_arm_m;
  const double eta = electrical_angle_rad(position_m, parameters_.pole_pitch_m) + set.phase_offset_rad +
                     orientation_(track_position);
  const Complex z{std::cos(eta), std::sin(eta)};
  const Complex z2 = multiply(z, z);
  const Complex z5 = multiply(multiply(z2, z2), z);
  const Complex z7 = multiply(z5, z2);
  const double h5 = parameters_.fifth_harmonic_relative;
  const double h7 = parameters_.seventh_harmonic_relative;
  const double mu = parameters_.orthogonal_ratio;
  const double scale = 2.0 / 3.0 * set.motor_constant_N_per_A * (1.0 + intensity_(track_position));
  // Fundamental of phase p: e^{i(η + φ_p)}, φ = 0, +2π/3, −2π/3.
  const Complex shift[3] = {{1.0, 0.0},
                            {std::cos(kTwoPiOverThree), std::sin(kTwoPiOverThree)},
                            {std::cos(kTwoPiOverThree), -std::sin(kTwoPiOverThree)}};
  Eigen::Vector3d column[3];
  for (int p = 0; p < 3; ++p) {
    const auto pi = static_cast<std::size_t>(p);
    const Complex e1 = multiply(z, shift[p]);
    const Complex e5 = multiply(z5, {fifth_rotation_[pi].cos, fifth_rotation_[pi].sin});
    const Complex e7 = multiply(z7, {seventh_rotation_[pi].cos, seventh_rotation_[pi].sin});
    const double s = e1.im + h5 * e5.im + h7 * e7.im;
    const double c = e1.re + h5 * e5.re + h7 * e7.re;
    const double phase_scale = scale * phase_gain_[l][pi];
    column[p] = phase_scale * Eigen::Vector3d(s, mu * c, set.lever_arm_m * mu * c + set.driving_force_lever_arm_m * s);
  }
  // Star constraint (5): i_c = −i_a − i_b.
  CoilGain result;
  result.col(0) = column[0] - column[2];
  result.col(1) = column[1] - column[2];
  return result;
}

void ElectromagneticTruth::stacked_gain(double position_m, StackedGain& gain_N_per_A) const noexcept {
  gain_N_per_A.resize(3, 2 * count_);
  for (int l = 0; l < count_; ++l) gain_N_per_A.middleCols<2>(2 * l) = gain(l, position_m);
}

Wrench ElectromagneticTruth::cogging(double position_m) const noexcept {
  Wrench force = Wrench::Zero();
  if (max_cogging_order_ > 0) {
    const double theta = electrical_angle_rad(position_m, parameters_.pole_pitch_m);
    const Complex z{std::cos(theta), std::sin(theta)};
    std::array<Complex, 65> power;  // z^n, n ≤ 64 (validated)
    power[0] = {1.0, 0.0};
    for (int n = 1; n <= max_cogging_order_; ++n) {
      power[static_cast<std::size_t>(n)] = multiply(power[static_cast<std::size_t>(n - 1)], z);
    }
    for (std::size_t h = 0; h < cogging_order_.size(); ++h) {
      const Complex zn = power[static_cast<std::size_t>(cogging_order_[h])];
      // A·sin(nθ + φ) = A cos φ·sin nθ + A sin φ·cos nθ
      force += cogging_cos_[h] * zn.im + cogging_sin_[h] * zn.re;
    }
  }
  for (int q = 0; q < 3; ++q) force[q] += cogging_slow_[static_cast<std::size_t>(q)](position_m);
  force -= parameters_.cogging_spring_rate_N_N_Nm_per_m * (position_m - parameters_.cogging_spring_neutral_m);
  return force;
}

Wrench ElectromagneticTruth::direction_dependent(double velocity_m_per_s) const noexcept {
  return parameters_.direction_dependent_N_N_Nm *
         std::tanh(velocity_m_per_s / parameters_.direction_smoothing_velocity_m_per_s);
}

Wrench ElectromagneticTruth::wrench(double position_m, double velocity_m_per_s,
                                    const CurrentVector& currents_A) const noexcept {
  Wrench force = cogging(position_m) + direction_dependent(velocity_m_per_s);
  for (int l = 0; l < count_; ++l) force.noalias() += gain(l, position_m) * currents_A.segment<2>(2 * l);
  return force;
}

}  // namespace clm::sim
