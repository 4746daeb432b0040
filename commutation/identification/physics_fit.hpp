#pragma once
// The physics-only fit θ*_phy of eq. (26) (docs/commutation.md §8): A, B of
// eq. (24) without networks, by least squares per direction. The PGNN and
// the spline fits start from it and regularise towards it. No I/O.

#include <Eigen/Core>

#include "commutation/identification/dataset.hpp"
#include "commutation/types.hpp"

namespace clm::identification {

/// Physics-only model: A, B of eq. (24) without networks, least squares per
/// direction. This is θ*_phy of eq. (26) (docs/commutation.md §8). Throws
/// std::invalid_argument for fewer than 10 samples or when the currents do
/// not excite both columns of K.
void fit_physics_only(const CoilSetDataset& data, double pole_pitch_m, CoilGain& a, CoilGain& b);

/// θ*_phy,q of direction q (0: y, 1: x, 2: z) as [A_q0, A_q1, B_q0, B_q1], the
/// order in which the linear parameters of eq. (29) begin.
Eigen::Vector4d physics_target(const CoilGain& a, const CoilGain& b, int q);

}  // namespace clm::identification
