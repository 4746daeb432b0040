#pragma once
// Seeded random models for property tests: a classical motor plus networks or
// splines with random parameters of realistic size.

#include <random>

#include "commutation/model.hpp"

namespace clm::test {

/// Classical coil sets spread along the translator, k ≈ 60 N/A, ζ ≈ −0.5 rad.
std::vector<ClassicalCoilSet> random_classical_coil_sets(int coil_sets, std::mt19937_64& rng);

/// A PGNN model: the classical A, B plus networks with random weights whose
/// outputs are a few percent of the motor constant, cogging of a few newtons,
/// and random physics-part harmonics of the given orders of the same sizes.
ElectromagneticModel random_pgnn_model(int coil_sets, double pole_pitch_m, std::mt19937_64& rng,
                                       const std::vector<int>& column_hidden = {2},
                                       const std::vector<int>& cogging_hidden = {16},
                                       const HarmonicOrders& harmonics = {});

/// A spline model of the same kind.
ElectromagneticModel random_spline_model(int coil_sets, double pole_pitch_m, std::mt19937_64& rng);

}  // namespace clm::test
