#pragma once
// A position-dependent learned law (PGNN, spline) used only where its model
// was identified: outside that range it blends, C1 over kBlendMarginPolePitches
// pole pitches, to a classical law (12) (docs/servod.md, "What a law may cost
// and mean"; docs/design-decisions.md, "A model's law outside its data").
// Beyond its data a model extrapolates (a PGNN's tanh layers, a spline's
// clamped end), to gains 0.01–35 times the motor's; the classical law's gain
// is the calibration's everywhere. No I/O; commutate() does not allocate.

#include <span>

#include "commutation/commutator.hpp"
#include "commutation/model.hpp"

namespace clm {

/// Width of the blend beyond each end of the identified range, in pole
/// pitches (a quarter: 7.5 mm on config/motor-sim.yaml's 30 mm).
inline constexpr double kBlendMarginPolePitches = 0.25;

/// Where a model was identified: a PGNN's data map to network inputs [−1, 1]
/// (offset ± scale of its position_normalisation), a spline's knots span its
/// data [start_m, end_m]. low_m ≤ high_m for a valid model.
struct IdentifiedRange {
  double low_m = 0.0;
  double high_m = 0.0;
};
IdentifiedRange identified_range(const ElectromagneticModel& model) noexcept;

/// The model law's weight at `position_m`: 1 inside [low_m, high_m], 0 at
/// `margin_m` and farther outside, 1 − (3s² − 2s³) at s = distance/margin_m
/// between (continuous with its first derivative). margin_m > 0.
double model_law_weight(const IdentifiedRange& range, double margin_m, double position_m) noexcept;

/// The law the daemon uses for a PGNN or spline model: ModelCommutator on
/// `model` where the weight is 1 (its output exactly), ClassicalCommutator on
/// `outside` where it is 0 (its output exactly), and between them the
/// currents w·i_model + (1 − w)·i_classical with their setpoints by eq. (39).
/// Blending currents, not gains, keeps the force the motor makes between the
/// two laws' (it is linear in the currents). `outside` is the calibration in
/// use, or the drive's own constants when none is loaded (the decision is the
/// caller's; the daemon's: docs/servod.md). Keeps a reference to `model`,
/// which must outlive it. Throws std::invalid_argument as the two laws do.
class RangeBlendedCommutator final : public CommutationLaw {
 public:
  RangeBlendedCommutator(const ElectromagneticModel& model, std::span<const ClassicalEstimate> outside,
                         const DriveCommutation& drive, const ModelCommutatorOptions& options = {});
  int coil_sets() const noexcept override { return model_law_.coil_sets(); }
  void commutate(double position_m, const Wrench& desired, CommutationOutput& out) const noexcept override;

  double weight(double position_m) const noexcept { return model_law_weight(range_, margin_m_, position_m); }
  const IdentifiedRange& range() const noexcept { return range_; }
  double margin_m() const noexcept { return margin_m_; }
  std::span<const ClassicalEstimate> outside() const noexcept {
    return {outside_.data(), static_cast<std::size_t>(model_law_.coil_sets())};
  }

 private:
  ModelCommutator model_law_;
  ClassicalCommutator classical_law_;
  std::array<ClassicalEstimate, kMaxCoilSets> outside_{};
  IdentifiedRange range_;
  double margin_m_ = 0.0;
  double pole_pitch_m_ = 0.0;
  DriveCommutation drive_;
  PhaseConvention convention_;
};

}  // namespace clm
