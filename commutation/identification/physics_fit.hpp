#pragma once
// The physics-only fit θ*_phy of eq. (26) (docs/commutation.md §8): A, B of
// eq. (24) without networks, by least squares per direction. The PGNN and
// the spline fits start from it and regularise towards it. No I/O.

#include <Eigen/Core>

#include "commutation/identification/dataset.hpp"
#include "commutation/identification/nuisance.hpp"
#include "commutation/types.hpp"

namespace clm::identification {

/// Physics-only model: A, B of eq. (24) without networks, and a constant
/// force beside them (the mean of cogging and cable forces, which the full
/// model carries in its cogging term; without it the mean would bias A and B,
/// and eq. (26) pulls every model towards them). With
/// direction_smoothing_m_per_s > 0 and velocities in the data, the
/// direction-dependent force C·tanh(ẏ/v_c) is fitted beside them too.
struct PhysicsFit {
  CoilGain a_N_per_A = CoilGain::Zero();
  CoilGain b_N_per_A = CoilGain::Zero();
  Wrench constant = Wrench::Zero();  ///< [N, N, N·m]
  DirectionForce direction;          ///< amplitude zero without a term
};

/// θ*_phy of eq. (26) (docs/commutation.md §8), least squares per direction.
/// Throws std::invalid_argument for fewer than 10 samples or when the
/// currents do not excite both columns of K.
PhysicsFit fit_physics_only(const CoilSetDataset& data, double pole_pitch_m, double direction_smoothing_m_per_s);

/// The direction-dependent force that `data` can carry with smoothing v_c:
/// none when v_c is 0 or the data have no velocities.
DirectionForce direction_shape(const CoilSetDataset& data, double direction_smoothing_m_per_s);

/// θ*_phy,q of direction q (0: y, 1: x, 2: z) as [A_q0, A_q1, B_q0, B_q1], the
/// order in which the linear parameters of eq. (29) begin.
Eigen::Vector4d physics_target(const CoilGain& a, const CoilGain& b, int q);

}  // namespace clm::identification
