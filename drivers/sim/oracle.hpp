#pragma once
// The oracle commutation: the exact minimum-power inverse of the simulator's
// static truth. It shows the best any static (position-only) model can do;
// what remains of the commutation error is the direction-dependent force,
// the sensor noise and bias, and the motion within a control period.

#include "commutation/commutator.hpp"
#include "drivers/sim/electromagnetics.hpp"

namespace clm::sim {

class OracleCommutator final : public clm::CommutationLaw {
 public:
  /// Keeps a reference to `truth` (e.g. SimulatedMotor::electromagnetics()),
  /// which must outlive the oracle. `drive` is the commutation of the drive
  /// the setpoints are for.
  OracleCommutator(const ElectromagneticTruth& truth, const DriveCommutation& drive,
                   const ModelCommutatorOptions& options = {});

  int coil_sets() const noexcept override { return truth_->coil_sets(); }
  /// Stacks the true K^l(y), takes the static cogging F_cog(y) and calls
  /// commutate_with_gain: currents and setpoints for `desired` [N, N, N·m] at
  /// `position_m`. No allocation.
  void commutate(double position_m, const Wrench& desired, CommutationOutput& out) const noexcept override;

 private:
  const ElectromagneticTruth* truth_;
  DriveCommutation drive_;
  ModelCommutatorOptions options_;
};

}  // namespace clm::sim
