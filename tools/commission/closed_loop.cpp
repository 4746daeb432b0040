#include "tools/commission/closed_loop.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace clm::commission {

ClosedLoopRecord run_closed_loop(sim::SimulatedMotor& motor, const control::MoveProgram& program,
                                 control::PositionController controller, const LoopCommutation& commutation,
                                 const ClosedLoopOptions& options) {
  const int coil_sets = motor.coil_sets();
  if (commutation.law != nullptr && commutation.law->coil_sets() != coil_sets) {
    throw std::invalid_argument("closed loop: the commutation law has " +
                                std::to_string(commutation.law->coil_sets()) + " coil sets, the motor " +
                                std::to_string(coil_sets));
  }
  if (commutation.law == nullptr &&
      (commutation.experiment_coil_set < 0 || commutation.experiment_coil_set >= coil_sets)) {
    throw std::invalid_argument("closed loop: experiment coil set " + std::to_string(commutation.experiment_coil_set) +
                                " outside 0.." + std::to_string(coil_sets - 1));
  }
  if (!(options.extra_time_s >= 0.0) || !std::isfinite(options.extra_time_s)) {
    throw std::invalid_argument("closed loop: extra_time_s must be finite and not negative");
  }
  const double period_s = controller.pid().period_s();
  const auto periods = static_cast<long>(std::ceil((program.duration_s() + options.extra_time_s) / period_s - 1e-9));

  ClosedLoopRecord record;
  record.coil_sets = coil_sets;
  record.period_s = period_s;
  record.commutation = commutation;
  record.samples.resize(static_cast<std::size_t>(periods));

  if (options.reset_motor) motor.reset(program.start_m());
  controller.reset();
  const double start_s = motor.truth().time_s;

  CommutationOutput commutated;
  commutated.currents_A.resize(2 * coil_sets);
  std::array<DriveSetpoint, kMaxCoilSets> setpoints{};
  const std::span<const DriveSetpoint> command(setpoints.data(), static_cast<std::size_t>(coil_sets));

  sim::SensorFrame frame = motor.sense();
  for (long k = 0; k < periods; ++k) {
    // Time since the start in whole periods, so the reference is sampled on
    // the same grid however long the run.
    const double t_now = static_cast<double>(k) * period_s;
    const double t_next = static_cast<double>(k + 1) * period_s;
    const control::ReferenceSample now = program.sample(t_now);
    const control::ReferenceSample next = program.sample(t_next);
    const double force_demand_N = controller.update(now, next, frame.position_m);
    const Wrench desired(force_demand_N, 0.0, 0.0);

    if (commutation.law != nullptr) {
      commutation.law->commutate(frame.position_m, desired, commutated);
      for (int l = 0; l < coil_sets; ++l) setpoints[static_cast<std::size_t>(l)] = commutated.setpoints[static_cast<std::size_t>(l)];
    } else {
      for (int l = 0; l < coil_sets; ++l) {
        setpoints[static_cast<std::size_t>(l)] = l == commutation.experiment_coil_set
                                                     ? DriveSetpoint{force_demand_N, commutation.experiment_delta_rad}
                                                     : DriveSetpoint{0.0, 0.0};
      }
    }
    motor.command(command, true);
    motor.step(period_s);
    frame = motor.sense();

    const sim::TruthState truth = motor.truth();
    ClosedLoopSample& sample = record.samples[static_cast<std::size_t>(k)];
    sample.t_s = frame.time_s - start_s;
    sample.r_m = next.position_m;
    sample.y_m = frame.position_m;
    sample.force_demand_N = force_demand_N;
    sample.measured = frame.wrench;
    sample.desired = desired;
    sample.coil_set = commutation.law == nullptr ? commutation.experiment_coil_set + 1 : 0;
    sample.setpoints = setpoints;
    sample.currents_A = truth.currents_A;
    sample.true_position_m = truth.position_m;
    sample.true_velocity_m_per_s = truth.velocity_m_per_s;
    sample.status_word = motor.status().word;
    if (record.first_fault_sample < 0 && (sample.status_word & sim::kStatusFault) != 0) record.first_fault_sample = k;
  }
  record.final_status = motor.status();
  return record;
}

std::vector<Eigen::Vector3d> ClosedLoopRecord::measured_wrenches() const {
  std::vector<Eigen::Vector3d> result;
  result.reserve(samples.size());
  for (const auto& sample : samples) result.push_back(sample.measured);
  return result;
}

std::vector<Eigen::Vector3d> ClosedLoopRecord::desired_wrenches() const {
  std::vector<Eigen::Vector3d> result;
  result.reserve(samples.size());
  for (const auto& sample : samples) result.push_back(sample.desired);
  return result;
}

std::vector<double> ClosedLoopRecord::measured_positions_m() const {
  std::vector<double> result;
  result.reserve(samples.size());
  for (const auto& sample : samples) result.push_back(sample.y_m);
  return result;
}

std::vector<double> ClosedLoopRecord::magnitudes_N(int coil_set) const {
  if (coil_set < 0 || coil_set >= coil_sets) {
    throw std::out_of_range("closed-loop record: coil set " + std::to_string(coil_set) + " outside 0.." +
                            std::to_string(coil_sets - 1));
  }
  std::vector<double> result;
  result.reserve(samples.size());
  for (const auto& sample : samples) result.push_back(sample.magnitude_N(coil_set));
  return result;
}

std::vector<double> ClosedLoopRecord::driving_forces_N() const {
  std::vector<double> result;
  result.reserve(samples.size());
  for (const auto& sample : samples) result.push_back(sample.measured.x());
  return result;
}

std::vector<double> ClosedLoopRecord::force_demands_N() const {
  std::vector<double> result;
  result.reserve(samples.size());
  for (const auto& sample : samples) result.push_back(sample.force_demand_N);
  return result;
}

std::vector<double> ClosedLoopRecord::tracking_errors_m() const {
  std::vector<double> result;
  result.reserve(samples.size());
  for (const auto& sample : samples) result.push_back(sample.r_m - sample.y_m);
  return result;
}

std::vector<control::ReferenceSample> ClosedLoopRecord::reference(const control::MoveProgram& program) const {
  // The reference the controller used for each sample's force demand: the
  // sample at the start of the period, t_s − T.
  std::vector<control::ReferenceSample> result;
  result.reserve(samples.size());
  for (std::size_t k = 0; k < samples.size(); ++k) result.push_back(program.sample(static_cast<double>(k) * period_s));
  return result;
}

}  // namespace clm::commission
