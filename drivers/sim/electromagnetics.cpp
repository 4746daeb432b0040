#include "drivers/sim/electromagnetics.hpp"

#include <algorithm>
#include <cmath>

#include "commutation/elementary.hpp"
#include "drivers/sim/random.hpp"

namespace clm::sim {
namespace {

// Independent random streams of the truth (see stream_seed).
enum TruthStream : std::uint64_t {
  kStreamMagnetIntensity = 1,
  kStreamMagnetOrientation = 2,
  kStreamHarmonicPhases = 3,
  kStreamPhaseGains = 4,
  kStreamCoggingPhases = 5,
  kStreamCoggingSlow = 6,
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
  if (variation.rms != 0.0) {
    draw(std::span<const double>(&variation.rms, 1), variation.correlation_length_m, track_start_m, track_end_m, seed);
  }
}

SmoothRandomFunction::SmoothRandomFunction(const Wrench& rms, double correlation_length_m, double track_start_m,
                                           double track_end_m, std::uint64_t seed)
    : centre_m_(0.5 * (track_start_m + track_end_m)) {
  if (!rms.isZero(0.0)) draw(std::span<const double>(rms.data(), 3), correlation_length_m, track_start_m, track_end_m, seed);
}

void SmoothRandomFunction::draw(std::span<const double> rms, double correlation_length_m, double track_start_m,
                                double track_end_m, std::uint64_t seed) {
  const double margin = correlation_length_m;
  basis_.start_m = track_start_m - margin;
  basis_.end_m = track_end_m + margin;
  const double intervals = std::ceil((basis_.end_m - basis_.start_m) / correlation_length_m);
  // MotorParameters::validate refuses this for a motor; direct users get the same refusal.
  if (!(intervals <= kMaxTrackKnots)) {
    throw ParameterError("smooth variation: correlation length " + std::to_string(correlation_length_m) +
                         " m gives " + std::to_string(intervals) + " knot intervals over [" +
                         std::to_string(track_start_m) + ", " + std::to_string(track_end_m) + "] m; at most " +
                         std::to_string(static_cast<long>(kMaxTrackKnots)));
  }
  basis_.intervals = std::max(1, static_cast<int>(intervals));
  inverse_spacing_per_m_ = 1.0 / basis_.spacing_m();
  components_ = static_cast<int>(rms.size());
  coefficients_.resize(static_cast<std::size_t>(basis_.size() * components_));
  RandomStream random(seed);
  // Component by component, so that component c draws the same numbers
  // whatever the RMS of the others.
  for (int c = 0; c < components_; ++c) {
    const double scale = rms[static_cast<std::size_t>(c)] / std::sqrt(kMeanSplineVariance);
    for (int j = 0; j < basis_.size(); ++j) {
      coefficients_[static_cast<std::size_t>(j * components_ + c)] = scale * random.normal();
    }
  }
}

int SmoothRandomFunction::span(double track_position_m, double value[4]) const noexcept {
  const double u = (std::clamp(track_position_m, basis_.start_m, basis_.end_m) - basis_.start_m) * inverse_spacing_per_m_;
  const int interval = std::clamp(static_cast<int>(u), 0, basis_.intervals - 1);  // u ≥ 0: truncation is floor
  const double t = u - interval;
  const double s = 1.0 - t;
  const double t2 = t * t;
  const double t3 = t2 * t;
  value[0] = s * s * s / 6.0;
  value[1] = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
  value[2] = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0;
  value[3] = t3 / 6.0;
  return interval;
}

double SmoothRandomFunction::operator()(double track_position_m) const noexcept {
  double result = slope_per_m_ * (track_position_m - centre_m_);
  if (components_ > 0) {
    double value[4];
    const int first = span(track_position_m, value);
    for (int k = 0; k < 4; ++k) result += value[k] * coefficients_[static_cast<std::size_t>((first + k) * components_)];
  }
  return result;
}

Wrench SmoothRandomFunction::wrench(double track_position_m) const noexcept {
  if (components_ < 3) return Wrench((*this)(track_position_m), 0.0, 0.0);
  Wrench result = Wrench::Constant(slope_per_m_ * (track_position_m - centre_m_));
  double value[4];
  const int first = span(track_position_m, value);
  for (int k = 0; k < 4; ++k) {
    for (int c = 0; c < 3; ++c) result[c] += value[k] * coefficients_[static_cast<std::size_t>((first + k) * 3 + c)];
  }
  return result;
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
    const auto [sin5, cos5] = elementary::sin_cos(angle5);
    const auto [sin7, cos7] = elementary::sin_cos(angle7);
    fifth_rotation_[static_cast<std::size_t>(p)] = {cos5, sin5};
    seventh_rotation_[static_cast<std::size_t>(p)] = {cos7, sin7};
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
      const auto [sin_phase, cos_phase] = elementary::sin_cos(phase);
      cos_part[q] = harmonic.amplitude_N_N_Nm[q] * cos_phase;
      sin_part[q] = harmonic.amplitude_N_N_Nm[q] * sin_phase;
    }
    cogging_order_.push_back(harmonic.order);
    cogging_cos_.push_back(cos_part);
    cogging_sin_.push_back(sin_part);
    max_cogging_order_ = std::max(max_cogging_order_, harmonic.order);
  }
  cogging_slow_ = SmoothRandomFunction(parameters_.cogging_slow_rms_N_N_Nm, parameters_.cogging_slow_correlation_length_m,
                                       travel_min_m, travel_max_m, stream_seed(seed, kStreamCoggingSlow));
}

void ElectromagneticTruth::phase_functions(int coil_set, double position_m, double s[3], double c[3]) const noexcept {
  const auto l = static_cast<std::size_t>(coil_set);
  const CoilSetParameters& set = parameters_.coil_sets[l];
  const double track_position = position_m + set.lever_arm_m;
  const double eta = electrical_angle_rad(position_m, parameters_.pole_pitch_m) + set.phase_offset_rad +
                     orientation_(track_position);
  const auto [sin_eta, cos_eta] = elementary::sin_cos(eta);
  const Complex z{cos_eta, sin_eta};
  const Complex z2 = multiply(z, z);
  const Complex z5 = multiply(multiply(z2, z2), z);
  const Complex z7 = multiply(z5, z2);
  const double h5 = parameters_.fifth_harmonic_relative;
  const double h7 = parameters_.seventh_harmonic_relative;
  const double scale = 2.0 / 3.0 * set.motor_constant_N_per_A * (1.0 + intensity_(track_position));
  // e^{iφ_p}, φ = 0, +2π/3, −2π/3: the fundamental of phase p is z·e^{iφ_p}.
  constexpr double kCos120 = -0.5;
  const double sin120 = std::sqrt(3.0) / 2.0;
  const Complex shift[3] = {{1.0, 0.0}, {kCos120, sin120}, {kCos120, -sin120}};
  for (int p = 0; p < 3; ++p) {
    const auto pi = static_cast<std::size_t>(p);
    const Complex e1 = multiply(z, shift[p]);
    const Complex e5 = multiply(z5, {fifth_rotation_[pi].cos, fifth_rotation_[pi].sin});
    const Complex e7 = multiply(z7, {seventh_rotation_[pi].cos, seventh_rotation_[pi].sin});
    const double phase_scale = scale * phase_gain_[l][pi];
    s[p] = phase_scale * (e1.im + h5 * e5.im + h7 * e7.im);
    c[p] = phase_scale * (e1.re + h5 * e5.re + h7 * e7.re);
  }
}

void ElectromagneticTruth::position_terms(double position_m, PositionTerms& terms) const noexcept {
  terms.position_m = position_m;
  for (int l = 0; l < count_; ++l) {
    const auto index = static_cast<std::size_t>(l);
    phase_functions(l, position_m, terms.s[index].data(), terms.c[index].data());
  }
  terms.cogging_N_N_Nm = cogging(position_m);
}

CoilGain ElectromagneticTruth::gain(int coil_set, double position_m) const noexcept {
  double s[3];
  double c[3];
  phase_functions(coil_set, position_m, s, c);
  return gain(coil_set, s, c);
}

CoilGain ElectromagneticTruth::gain(int coil_set, const double s[3], const double c[3]) const noexcept {
  const CoilSetParameters& set = parameters_.coil_sets[static_cast<std::size_t>(coil_set)];
  const double mu = parameters_.orthogonal_ratio;
  const double lever_x = set.lever_arm_m * mu;
  const double lever_y = set.driving_force_lever_arm_m;
  // Column p of eq. (7) is [s_p, μ·c_p, d·μ·c_p + e·s_p]; the star constraint
  // (5), i_c = −i_a − i_b, leaves columns a − c and b − c.
  CoilGain result;
  for (int column = 0; column < 2; ++column) {
    const double ds = s[column] - s[2];
    const double dc = c[column] - c[2];
    result(0, column) = ds;
    result(1, column) = mu * dc;
    result(2, column) = lever_x * dc + lever_y * ds;
  }
  return result;
}

void ElectromagneticTruth::stacked_gain(double position_m, StackedGain& gain_N_per_A) const noexcept {
  gain_N_per_A.resize(3, 2 * count_);
  for (int l = 0; l < count_; ++l) gain_N_per_A.middleCols<2>(2 * l) = gain(l, position_m);
}

Wrench ElectromagneticTruth::cogging(double position_m) const noexcept {
  Wrench force = cogging_slow_.wrench(position_m);
  if (max_cogging_order_ > 0) {
    const double theta = electrical_angle_rad(position_m, parameters_.pole_pitch_m);
    const auto [sin_theta, cos_theta] = elementary::sin_cos(theta);
  const Complex z{cos_theta, sin_theta};
    Complex zn{1.0, 0.0};
    int n = 0;
    // Harmonics in the order given; z^n by repeated multiplication (orders ≤ 64).
    for (std::size_t h = 0; h < cogging_order_.size(); ++h) {
      if (cogging_order_[h] < n) {
        zn = {1.0, 0.0};
        n = 0;
      }
      for (; n < cogging_order_[h]; ++n) zn = multiply(zn, z);
      // A·sin(nθ + φ) = A cos φ·sin nθ + A sin φ·cos nθ
      force += cogging_cos_[h] * zn.im + cogging_sin_[h] * zn.re;
    }
  }
  force -= parameters_.cogging_spring_rate_N_N_Nm_per_m * (position_m - parameters_.cogging_spring_neutral_m);
  return force;
}

Wrench ElectromagneticTruth::direction_dependent(double velocity_m_per_s) const noexcept {
  return parameters_.direction_dependent_N_N_Nm * elementary::tanh(direction_ratio(velocity_m_per_s));
}

Wrench ElectromagneticTruth::wrench(double position_m, double velocity_m_per_s,
                                    const CurrentVector& currents_A) const noexcept {
  PositionTerms terms;
  position_terms(position_m, terms);
  return wrench(terms, velocity_m_per_s, currents_A);
}

Wrench ElectromagneticTruth::wrench(const PositionTerms& terms, double velocity_m_per_s,
                                    const CurrentVector& currents_A) const noexcept {
  Wrench force = terms.cogging_N_N_Nm + direction_dependent(velocity_m_per_s);
  for (int l = 0; l < count_; ++l) {
    const auto index = static_cast<std::size_t>(l);
    force.noalias() += gain(l, terms.s[index].data(), terms.c[index].data()) * currents_A.segment<2>(2 * l);
  }
  return force;
}

double ElectromagneticTruth::driving_force_N(double position_m, double velocity_m_per_s,
                                             const CurrentVector& currents_A) const noexcept {
  PositionTerms terms;
  position_terms(position_m, terms);
  return driving_force_N(terms, elementary::tanh(direction_ratio(velocity_m_per_s)), currents_A);
}

double ElectromagneticTruth::driving_force_N(const PositionTerms& terms, double direction_tanh,
                                             const CurrentVector& currents_A) const noexcept {
  // Row y of wrench(); the same arithmetic, the other rows left out.
  double force = terms.cogging_N_N_Nm.x() + parameters_.direction_dependent_N_N_Nm.x() * direction_tanh;
  for (int l = 0; l < count_; ++l) {
    const auto& s = terms.s[static_cast<std::size_t>(l)];
    force += (s[0] - s[2]) * currents_A[2 * l] + (s[1] - s[2]) * currents_A[2 * l + 1];
  }
  return force;
}

}  // namespace clm::sim
