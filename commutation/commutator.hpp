#pragma once
// Commutation laws: the model-based analytic inverse (37) with the averaged
// cogging (35), and the classical law (12), both producing phase currents and
// setpoints for a drive with fixed commutation (39).

#include <array>
#include <optional>
#include <span>

#include "commutation/classical.hpp"
#include "commutation/model.hpp"
#include "commutation/transform.hpp"
#include "commutation/types.hpp"

namespace clm {

/// What the minimum-power commutation minimises (docs/commutation.md §6).
enum class PowerMetric {
  /// ‖[i_a^l, i_b^l]‖² summed over coil sets, as printed in eq. (10)/(36).
  kCurrentNorm,
  /// i_a² + i_b² + i_c² summed over coil sets: the dissipated power per ohm.
  kTruePower,
};

struct CommutationOutput {
  int coil_sets = 0;
  CurrentVector currents_A;                             ///< [i_a^1, i_b^1, ...] [A]
  std::array<DriveSetpoint, kMaxCoilSets> setpoints{};  ///< eq. (39) per coil set
  Wrench model_wrench{Wrench::Zero()};                  ///< F̂ the law's model predicts for the currents
  /// ∂F̂_y/∂i of the law's model at the position, one per current [N/A]: in
  /// SI units also each winding's back-EMF per velocity [V·s/m].
  CurrentVector driving_gain_N_per_A;
  double current_square_sum_A2 = 0.0;                   ///< Σ i_a² + i_b² + i_c² [A²]
  double singular_value_ratio = 1.0;                    ///< σ_min/σ_max of the weighted K̂ [-]
  bool damping_engaged = false;                         ///< the damped pseudo-inverse was used
};

/// A commutation law as the cycle uses it. commutate() does not allocate,
/// lock or throw.
class CommutationLaw {
 public:
  virtual ~CommutationLaw() = default;
  virtual int coil_sets() const noexcept = 0;
  /// Currents and drive setpoints for a desired wrench [N, N, N·m] at a position.
  virtual void commutate(double position_m, const Wrench& desired, CommutationOutput& out) const noexcept = 0;
};

struct ModelCommutatorOptions {
  PowerMetric power_metric = PowerMetric::kTruePower;
  PhaseConvention phase_convention = PhaseConvention::kSignedMagnitude;
  /// Below this ratio of smallest to largest singular value of the (weighted)
  /// K̂, the damped pseudo-inverse with λ = ratio·σ_max takes over.
  double min_singular_value_ratio = 1e-4;
};

/// Eq. (37): i = K̂_W^†(F* − F̂_cog), minimum power over the chosen metric, then
/// eq. (39) to setpoints. For L = 1 the system is underactuated and the
/// result is the least-squares wrench. Keeps a reference to `model`, which
/// must outlive it.
class ModelCommutator final : public CommutationLaw {
 public:
  ModelCommutator(const ElectromagneticModel& model, const DriveCommutation& drive,
                  const ModelCommutatorOptions& options = {});
  int coil_sets() const noexcept override { return model_->coil_set_count(); }
  void commutate(double position_m, const Wrench& desired, CommutationOutput& out) const noexcept override;

 private:
  const ElectromagneticModel* model_;
  std::optional<FusedPgnnEvaluator> fused_;  // when the model has one hidden layer per network
  DriveCommutation drive_;
  ModelCommutatorOptions options_;
};

/// Classical commutation (12) with per-coil-set constants (calibrated, or the
/// drive's own for the uncalibrated "original" law). Only the driving force is
/// commanded; F_x and T_z demands are ignored, as in the paper.
class ClassicalCommutator final : public CommutationLaw {
 public:
  ClassicalCommutator(std::span<const ClassicalEstimate> estimates, double pole_pitch_m,
                      const DriveCommutation& drive,
                      PhaseConvention convention = PhaseConvention::kSignedMagnitude);
  int coil_sets() const noexcept override { return count_; }
  void commutate(double position_m, const Wrench& desired, CommutationOutput& out) const noexcept override;

 private:
  std::array<ClassicalEstimate, kMaxCoilSets> estimates_{};
  int count_ = 0;
  double pole_pitch_m_ = 0.0;
  DriveCommutation drive_;
  PhaseConvention convention_;
};

/// The inverse behind ModelCommutator for any gain and cogging: minimum power
/// currents for `desired` − `cogging` through `gain` (3 × 2L), then eq. (39).
/// Used as well by the simulator's oracle with the exact truth. No allocation.
void commutate_with_gain(const StackedGain& gain, const Wrench& cogging, const Wrench& desired,
                         double position_m, double pole_pitch_m, const DriveCommutation& drive,
                         const ModelCommutatorOptions& options, CommutationOutput& out) noexcept;

/// Σ_l i_a² + i_b² + i_c² with i_c = −i_a − i_b [A²].
double current_square_sum(const CurrentVector& currents_A) noexcept;

}  // namespace clm
