// A learned law used only where its model was identified, blended C1 to the
// classical law outside (commutation/range_blend.hpp), and the law check of
// the law as used over the whole stroke (commutation/law_check.hpp).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include "commutation/classical.hpp"
#include "commutation/law_check.hpp"
#include "commutation/range_blend.hpp"
#include "support/allocation_counter.hpp"

using namespace clm;

namespace {

constexpr double kPolePitch = 0.03;
// The limits of config/servod.yaml with config/motor-sim.yaml: stroke ±0.12 m.
const LawLimits kLimits{1000.0, 67.0, -0.12, 0.12};
const DriveCommutation kDrive{67.0, -0.52};
// A calibration of config/motor-sim.yaml's motor.
const std::vector<ClassicalEstimate> kCalibration{{61.3, -0.54}, {61.6, -0.55}, {60.1, -0.55}};

/// config/motor-sim.yaml's truth as a PGNN identified on ±0.1 m that
/// extrapolates badly: coil set 2's gain is its column network alone,
/// 30·(tanh(w(u + 1.15)) − tanh(w(u − 1.15))) of u = y/0.1 m: 60 N/A on the
/// data and a little beyond, then 0 N/A (a coil set the law thinks dead)
/// from 0.115 m out, between the data's end and the stroke's.
ElectromagneticModel extrapolating_model() {
  const std::vector<ClassicalCoilSet> coil_sets{
      {61.3, -0.54, 0.1, -0.08}, {61.6, -0.55, 0.1, 0.0}, {60.1, -0.55, 0.1, 0.08}};
  ElectromagneticModel model = make_classical_model(kPolePitch, coil_sets, {2}, {16});
  model.normalisation = {0.0, 0.1};
  model.coil_sets[1].a_N_per_A.setZero();
  model.coil_sets[1].b_N_per_A.setZero();
  Network& column = model.coil_sets[1].column_a;
  const double w = 1000.0;
  column.layers[0].weights(0, 0) = w;
  column.layers[0].weights(1, 0) = w;
  column.layers[0].biases[0] = w * 1.15;
  column.layers[0].biases[1] = -w * 1.15;
  column.layers[1].weights(0, 0) = 30.0;
  column.layers[1].weights(0, 1) = -30.0;
  model.validate();
  return model;
}

bool same_output(const CommutationOutput& a, const CommutationOutput& b) {
  if (a.coil_sets != b.coil_sets || a.currents_A != b.currents_A || a.model_wrench != b.model_wrench) return false;
  for (int l = 0; l < a.coil_sets; ++l) {
    const auto& x = a.setpoints[static_cast<std::size_t>(l)];
    const auto& y = b.setpoints[static_cast<std::size_t>(l)];
    if (x.magnitude_N != y.magnitude_N || x.delta_rad != y.delta_rad) return false;
  }
  return a.current_square_sum_A2 == b.current_square_sum_A2 && a.singular_value_ratio == b.singular_value_ratio &&
         a.damping_engaged == b.damping_engaged;
}

}  // namespace

TEST_CASE("The model law's weight is 1 on the range, 0 a margin beyond, and C1 in between", "[range_blend]") {
  const IdentifiedRange range{-0.1, 0.1};
  const double margin = 0.0075;
  CHECK(model_law_weight(range, margin, 0.0) == 1.0);
  CHECK(model_law_weight(range, margin, 0.1) == 1.0);
  CHECK(model_law_weight(range, margin, -0.1) == 1.0);
  CHECK(model_law_weight(range, margin, 0.1075) == 0.0);
  CHECK(model_law_weight(range, margin, -0.12) == 0.0);
  CHECK(model_law_weight(range, margin, 0.1 + margin / 2) == Approx(0.5).epsilon(1e-12));
  CHECK(model_law_weight(range, margin, -0.1 - margin / 2) == Approx(0.5).epsilon(1e-12));
  // Value and slope meet at both ends of the margin; the slope is −1.5/margin in its middle.
  const double h = 1e-7;
  const auto slope = [&](double y) {
    return (model_law_weight(range, margin, y + h) - model_law_weight(range, margin, y - h)) / (2 * h);
  };
  for (const double end : {0.1, 0.1 + margin}) {
    CHECK(std::abs(slope(end)) < 1e-2);  // O(h/margin²) from the one-sided parabola; 200 mid-margin
    CHECK(std::abs(model_law_weight(range, margin, end + 1e-12) - model_law_weight(range, margin, end - 1e-12)) < 1e-9);
  }
  CHECK(slope(0.1 + margin / 2) == Approx(-1.5 / margin).epsilon(1e-6));
  CHECK(slope(-0.1 - margin / 2) == Approx(1.5 / margin).epsilon(1e-6));
}

TEST_CASE("A PGNN's range is its normalisation's ±1, a spline's its knot span", "[range_blend]") {
  ElectromagneticModel model = extrapolating_model();
  model.normalisation = {0.01, 0.09};
  const IdentifiedRange pgnn = identified_range(model);
  CHECK(pgnn.low_m == Approx(-0.08));
  CHECK(pgnn.high_m == Approx(0.1));
  model.kind = ModelKind::kSpline;
  model.spline_basis.start_m = -0.095;
  model.spline_basis.end_m = 0.097;
  const IdentifiedRange spline = identified_range(model);
  CHECK(spline.low_m == -0.095);
  CHECK(spline.high_m == 0.097);
}

TEST_CASE("A model that extrapolates to a dead coil set fails the whole-stroke check unblended and passes blended",
          "[range_blend][law_check]") {
  const ElectromagneticModel model = extrapolating_model();
  // (a) Unblended on the whole stroke: coil set 2 dead from 0.115 m out.
  const LawCheck unblended = check_model_law(model, kLimits);
  REQUIRE(unblended.verdict == LawVerdict::kGainOutOfRange);
  CHECK(unblended.coil_set == 2);
  CHECK(unblended.position_m < -0.115);
  CHECK(unblended.value < 1.0);
  // (b) Blended to a calibration (or to the drive's own constants): the
  // model drives the axis to 0.1075 m only, where its gain is 60 N/A.
  CHECK(check_blended_law(model, kCalibration, kLimits).accepted());
  const std::vector<ClassicalEstimate> nominal(3, {kDrive.motor_constant_N_per_A, kDrive.phase_offset_rad});
  CHECK(check_blended_law(model, nominal, kLimits).accepted());
  // A classical part with a dead coil set is refused where it drives the axis,
  // the first grid point beyond the margin's start.
  std::vector<ClassicalEstimate> dead = kCalibration;
  dead[2].motor_constant_N_per_A = 1e-300;
  const LawCheck outside = check_blended_law(model, dead, kLimits);
  REQUIRE(outside.verdict == LawVerdict::kGainOutOfRange);
  CHECK(outside.coil_set == 3);
  CHECK(outside.position_m == -0.12);
  // A model already dead on its data is refused blended too.
  ElectromagneticModel narrow = model;
  narrow.normalisation = {0.0, 0.2};  // the step at ±0.23 m of y ... the data said ±0.2 m
  narrow.coil_sets[1].column_a.layers[0].biases[0] = 1000.0 * 0.5;  // now dead below y = −0.1 m
  const LawCheck dead_on_data = check_blended_law(narrow, kCalibration, kLimits);
  REQUIRE(dead_on_data.verdict == LawVerdict::kGainOutOfRange);
  CHECK(dead_on_data.coil_set == 2);
  CHECK(dead_on_data.position_m < -0.1);
}

TEST_CASE("Blended, the law is the model's on its range and the classical law beyond the margin, exactly",
          "[range_blend]") {
  const ElectromagneticModel model = extrapolating_model();
  const RangeBlendedCommutator blended(model, kCalibration, kDrive);
  const ModelCommutator model_law(model, kDrive);
  const ClassicalCommutator classical_law(kCalibration, kPolePitch, kDrive);
  CHECK(blended.range().low_m == -0.1);
  CHECK(blended.range().high_m == 0.1);
  CHECK(blended.margin_m() == 0.25 * kPolePitch);
  const Wrench desired(150.0, 10.0, -2.0);
  CommutationOutput a, b;
  int inside = 0, outside = 0;
  for (double y = -0.12; y <= 0.12 + 1e-12; y += 0.0003) {
    blended.commutate(y, desired, a);
    if (std::abs(y) <= 0.1) {
      model_law.commutate(y, desired, b);
      CHECK(same_output(a, b));
      ++inside;
    } else if (std::abs(y) >= 0.1 + blended.margin_m()) {
      classical_law.commutate(y, desired, b);
      CHECK(same_output(a, b));
      ++outside;
    }
  }
  for (const double y : {-0.1, 0.1}) {  // both ends of the range belong to the model
    blended.commutate(y, desired, a);
    model_law.commutate(y, desired, b);
    CHECK(same_output(a, b));
  }
  CHECK(inside > 600);
  CHECK(outside > 40);
}

TEST_CASE("The blended law's currents and setpoints are continuous across the margin", "[range_blend]") {
  const ElectromagneticModel model = extrapolating_model();
  const RangeBlendedCommutator blended(model, kCalibration, kDrive);
  const Wrench desired(150.0, 0.0, 0.0);
  const double margin = blended.margin_m();
  CommutationOutput before, after;
  // At the ends of the margin: no step.
  for (const double end : {0.1, 0.1 + margin, -0.1, -0.1 - margin}) {
    blended.commutate(end - 1e-10, desired, before);
    blended.commutate(end + 1e-10, desired, after);
    CHECK((after.currents_A - before.currents_A).cwiseAbs().maxCoeff() < 1e-6);
  }
  // Across it, 1 µm apart: no step bigger than the laws' own slopes allow
  // (a few hundred A/m: the commutation angle turns 2π per 30 mm; the blend
  // moves the currents by the two laws' difference over 7.5 mm).
  double largest_step_A = 0.0;
  blended.commutate(0.099, desired, before);
  for (double y = 0.099 + 1e-6; y <= 0.1095; y += 1e-6) {
    blended.commutate(y, desired, after);
    largest_step_A = std::max(largest_step_A, (after.currents_A - before.currents_A).cwiseAbs().maxCoeff());
    // The setpoints make the drive apply the blended currents (eq. 39).
    if (blended.weight(y) > 0.0 && blended.weight(y) < 1.0) {
      for (int l = 0; l < 3; ++l) {
        const Eigen::Vector2d applied =
            drive_phase_currents(kDrive, after.setpoints[static_cast<std::size_t>(l)], y, kPolePitch);
        CHECK((applied - after.currents_A.segment<2>(2 * l)).cwiseAbs().maxCoeff() < 1e-9);
      }
    }
    before = after;
  }
  CHECK(largest_step_A < 2e-3);
  // The two laws differ where they meet, so the blend is doing something.
  CommutationOutput model_out, classical_out;
  ModelCommutator(model, kDrive).commutate(0.1 + margin / 2, desired, model_out);
  ClassicalCommutator(kCalibration, kPolePitch, kDrive).commutate(0.1 + margin / 2, desired, classical_out);
  CHECK((model_out.currents_A - classical_out.currents_A).cwiseAbs().maxCoeff() > 0.1);
}

TEST_CASE("The blended law costs both laws and the blend", "[range_blend][law_check]") {
  const ElectromagneticModel model = extrapolating_model();
  CHECK(blended_law_cost(model) == model_law_cost(model) + classical_law_cost(3) + 50 + 3 * 50);
}

TEST_CASE("A blended commutation call does not allocate, in the range, the margin or beyond",
          "[range_blend][realtime]") {
  const ElectromagneticModel model = extrapolating_model();
  const RangeBlendedCommutator blended(model, kCalibration, kDrive);
  CommutationOutput out;
  out.currents_A.resize(6);
  test::AllocationScope scope;
  for (int call = 0; call < 100000; ++call) {
    blended.commutate(-0.12 + 0.24 * (call % 1000) / 999.0, {100.0, 1.0, 0.1}, out);
  }
  CHECK(scope.allocations() == 0);
}
