#include "drivers/sim/oracle.hpp"

#include <stdexcept>

namespace clm::sim {

OracleCommutator::OracleCommutator(const ElectromagneticTruth& truth, const DriveCommutation& drive,
                                   const ModelCommutatorOptions& options)
    : truth_(&truth), drive_(drive), options_(options) {
  if (!(drive.motor_constant_N_per_A > 0.0)) {
    throw ParameterError("oracle commutation: the drive motor constant must be positive");
  }
}

void OracleCommutator::commutate(double position_m, const Wrench& desired, CommutationOutput& out) const noexcept {
  StackedGain gain;
  truth_->stacked_gain(position_m, gain);
  commutate_with_gain(gain, truth_->cogging(position_m), desired, position_m, truth_->pole_pitch_m(), drive_,
                      options_, out);
}

}  // namespace clm::sim
