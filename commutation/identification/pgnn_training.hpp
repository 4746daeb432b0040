#pragma once
// Algorithm 2 for one coil set: the PGNN (eq. 24-25) by Levenberg–Marquardt
// (Ceres, a private dependency of this file) with seeded random restarts, and
// eq. (31) applied at the end. No I/O.

#include <cstdint>
#include <functional>

#include "commutation/identification/dataset.hpp"
#include "commutation/identification/report.hpp"
#include "commutation/model.hpp"

namespace clm::identification {

/// How Levenberg–Marquardt treats the parameters in which the PGNN is linear
/// (θ_L of eq. 29; docs/commutation.md, "Identification").
enum class PgnnSolver {
  kVariableProjection,  ///< θ_L by eq. (31) at every θ_NL, LM on θ_NL alone (Kaufman's Jacobian)
  kJointSchur,          ///< LM on θ_L and θ_NL together, θ_L eliminated by the Schur complement
};

/// The physics-part harmonics identification offers (docs/commutation.md,
/// "Harmonics in the physics part"): in K̂ the field harmonics 5 and 7 (a
/// three-phase winding in star sees the orders 6k ± 1; the 3rd cancels), in
/// the cogging the orders 1..6 (forces periodic in the pole pitch, up to the
/// sixth, where a three-phase motor's force ripple lies).
inline HarmonicOrders field_harmonic_orders() { return {{5, 7}, {1, 2, 3, 4, 5, 6}}; }

struct PgnnOptions {
  int column_hidden = 2;        ///< neurons of each column network of K̂ (paper: 2)
  int cogging_hidden = 16;      ///< neurons of the cogging network (paper: 16)
  double regularisation = 0.1;  ///< Λ = regularisation·I in eq. (26) (paper: 0.1)
  /// Harmonics of the electrical angle in the physics part beside A and B
  /// (HarmonicOrders; paper: none). Linear parameters, solved by eq. (31)
  /// with the output layers; the prior of eq. (26) acts on A and B alone.
  HarmonicOrders harmonics;
  int restarts = 5;             ///< seeded random initialisations, best kept
  std::uint64_t seed = 1;
  int restart_iterations = 40;  ///< LM iterations per restart, on the decimated training set
  int restart_decimation = 16;  ///< every n-th training sample is used for the restarts
  int final_iterations = 100;   ///< LM iterations polishing the best restart
  int final_decimation = 8;     ///< every n-th training sample is used for the polish
  // At 1 kHz the experiments sample the stroke every 30-500 µm, far finer
  // than anything the networks resolve (their narrowest tanh spans
  // millimetres); the decimated sets keep every position region. Eq. (31)
  // at the end always uses all training samples.
  int threads = 2;
  /// v_c of the direction-dependent force C·tanh(ẏ/v_c) identified beside
  /// the model (Remark 5.1); 0, or data without velocities: none.
  double direction_smoothing_m_per_s = 0.0;
  /// With held-out data, polish the chosen model once more on all samples
  /// (refit_pgnn_coil_set); false leaves it fit on the training blocks.
  bool refit_on_all_data = true;
  PgnnSolver solver = PgnnSolver::kVariableProjection;
};

struct PgnnProgress {
  int restart = 0;      ///< 0-based; restarts == polishing step
  int restarts = 0;
  double cost = 0.0;    ///< eq. (26) at the end of this step
};

/// Algorithm 2 for one coil set: returns A, B and the three networks. The
/// networks take `normalisation` of the position as input. Eq. (31) is
/// applied to the best parameters at the end, which guarantees eq. (32).
/// `progress` (optional) is called after every restart and the polish.
/// Throws std::invalid_argument for too few samples, network sizes outside
/// 1..Network::kMaxWidth, no restarts or a negative regularisation.
CoilSetModel identify_pgnn_coil_set(const CoilSetDataset& training, const CoilSetDataset& validation,
                                    double pole_pitch_m, const PositionNormalisation& normalisation,
                                    const PgnnOptions& options, IdentificationReport& report,
                                    const std::function<void(const PgnnProgress&)>& progress = {});

/// The model put to use: `trained` (and the direction-dependent force fitted
/// beside it) polished once more on training and validation together, then
/// eq. (31) on all of them; with empty `validation`, `trained` as it is.
/// Fills refit_on_all_data, model_fit, physics_fit, proposition_holds,
/// direction_force and regularised_cost of `report`.
CoilSetModel refit_pgnn_coil_set(const CoilSetModel& trained, const DirectionForce& trained_direction,
                                 const CoilSetDataset& training, const CoilSetDataset& validation, double pole_pitch_m,
                                 const PositionNormalisation& normalisation, const PgnnOptions& options,
                                 IdentificationReport& report);

}  // namespace clm::identification
