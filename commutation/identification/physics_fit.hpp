#pragma once
// The physics-only fit θ*_phy of eq. (26) (docs/commutation.md §8): A, B of
// eq. (24) without networks, by least squares per direction. The PGNN and
// the spline fits start from it and regularise towards it. No I/O.

#include <Eigen/Core>

#include "commutation/identification/dataset.hpp"
#include "commutation/identification/nuisance.hpp"
#include "commutation/types.hpp"

namespace clm::identification {

/// Physics-only model: A, B of eq. (24) without networks, least squares per
/// direction. This is θ*_phy of eq. (26) (docs/commutation.md §8). With
/// `direction_smoothing_m_per_s` > 0 and velocities in `data`, the
/// direction-dependent force C·tanh(ẏ/v_c) is fitted beside A and B and
/// returned in `direction` (else its amplitude is zero). Throws
/// std::invalid_argument for fewer than 10 samples or when the currents do
/// not excite both columns of K.
void fit_physics_only(const CoilSetDataset& data, double pole_pitch_m, double direction_smoothing_m_per_s, CoilGain& a,
                      CoilGain& b, DirectionForce& direction);

/// The direction-dependent force that `data` can carry with smoothing v_c:
/// none when v_c is 0 or the data have no velocities.
DirectionForce direction_shape(const CoilSetDataset& data, double direction_smoothing_m_per_s);

/// θ*_phy,q of direction q (0: y, 1: x, 2: z) as [A_q0, A_q1, B_q0, B_q1], the
/// order in which the linear parameters of eq. (29) begin.
Eigen::Vector4d physics_target(const CoilGain& a, const CoilGain& b, int q);

}  // namespace clm::identification
