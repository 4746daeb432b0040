#pragma once
// Records and samples with a distinct value in every field, and
// field-by-field checks of the decoded LCM messages against them.

#include <catch2/catch.hpp>

#include "daemon/telemetry/telemetry.hpp"

namespace clm::test {

/// A state whose fields all differ (so a swapped field is caught); `cycle`
/// shifts every value.
inline servo::CycleRecord make_state(std::int64_t cycle, int coil_sets = 3) {
  servo::CycleRecord s;
  const double k = static_cast<double>(cycle);
  s.utime = 1'700'000'000'000'000 + cycle * 1000;
  s.cycle = cycle;
  s.t_s = 1e-3 * k;
  s.r_m = 0.01 + 1e-6 * k;
  s.r_dot_m_per_s = 0.02 + 1e-6 * k;
  s.r_ddot_m_per_s2 = 0.03 + 1e-6 * k;
  s.y_m = 0.04 + 1e-6 * k;
  s.e_m = -0.03 - 1e-6 * k;
  s.F_star_N = 5.5 + k;
  s.u_fb_N = 1.25 + k;
  s.u_ff_N = 4.25 + k;
  s.Fy_star_N = 6.5 + k;
  s.Fx_star_N = -7.5 - k;
  s.Tz_star_Nm = 0.125 + k;
  s.force_measured = true;  // its Fy_N, Fx_N, Tz_Nm are a sensor frame
  s.Fy_N = 6.25 + k;
  s.Fx_N = -7.25 - k;
  s.Tz_Nm = 0.375 + k;
  s.commutation = servo::CommutationMode::kExperiment;
  s.coil_set = static_cast<int>(1 + cycle % coil_sets);
  s.delta_rad = cycle % 2 == 0 ? 0.0 : 1.5707963267948966;
  s.coil_sets = coil_sets;
  for (int l = 0; l < coil_sets; ++l) {
    s.magnitude_N[l] = 10.0 * (l + 1) + k;
    s.setpoint_delta_rad[l] = 0.1 * (l + 1) + 1e-3 * k;
    s.ia_A[l] = 0.5 * (l + 1) + 1e-3 * k;
    s.ib_A[l] = -0.25 * (l + 1) - 1e-3 * k;
  }
  s.damping_engaged = cycle % 3 == 0;
  s.current_square_sum_A2 = 2.5 + k;
  s.force_limited = cycle % 5 == 1;
  s.state = static_cast<servo::ServoState>(cycle % 3);
  s.program_running = cycle % 2 == 1;
  s.program_time_s = 0.75 + 1e-3 * k;
  s.drive_profile = cycle % 2 == 0 ? DriveProfile::kPhaseCurrent : DriveProfile::kMagnitudePhase;
  return s;
}

inline void check_state(const servo::CycleRecord& s, const clm_lcm::servo_state_t& m) {
  CHECK(m.utime == s.utime);
  CHECK(m.cycle == s.cycle);
  CHECK(m.t_s == s.t_s);
  CHECK(m.r_m == s.r_m);
  CHECK(m.r_dot_m_per_s == s.r_dot_m_per_s);
  CHECK(m.r_ddot_m_per_s2 == s.r_ddot_m_per_s2);
  CHECK(m.y_m == s.y_m);
  CHECK(m.e_m == s.e_m);
  CHECK(m.F_star_N == s.F_star_N);
  CHECK(m.u_fb_N == s.u_fb_N);
  CHECK(m.u_ff_N == s.u_ff_N);
  CHECK(m.Fy_star_N == s.Fy_star_N);
  CHECK(m.Fx_star_N == s.Fx_star_N);
  CHECK(m.Tz_star_Nm == s.Tz_star_Nm);
  CHECK(m.Fy_N == s.Fy_N);
  CHECK(m.Fx_N == s.Fx_N);
  CHECK(m.Tz_Nm == s.Tz_Nm);
  CHECK(m.commutation == static_cast<int>(s.commutation));
  CHECK(m.coil_set == s.coil_set);
  CHECK(m.delta_rad == s.delta_rad);
  REQUIRE(m.coil_sets == s.coil_sets);
  REQUIRE(m.magnitude_N.size() == static_cast<std::size_t>(s.coil_sets));
  REQUIRE(m.setpoint_delta_rad.size() == static_cast<std::size_t>(s.coil_sets));
  REQUIRE(m.ia_A.size() == static_cast<std::size_t>(s.coil_sets));
  REQUIRE(m.ib_A.size() == static_cast<std::size_t>(s.coil_sets));
  for (std::size_t l = 0; l < static_cast<std::size_t>(s.coil_sets); ++l) {
    CHECK(m.magnitude_N[l] == s.magnitude_N[l]);
    CHECK(m.setpoint_delta_rad[l] == s.setpoint_delta_rad[l]);
    CHECK(m.ia_A[l] == s.ia_A[l]);
    CHECK(m.ib_A[l] == s.ib_A[l]);
  }
  CHECK(static_cast<bool>(m.damping_engaged) == s.damping_engaged);
  CHECK(m.current_square_sum_A2 == s.current_square_sum_A2);
  CHECK(static_cast<bool>(m.force_limited) == s.force_limited);
  CHECK(m.state == static_cast<int>(s.state));
  CHECK(static_cast<bool>(m.program_running) == s.program_running);
  CHECK(m.program_time_s == s.program_time_s);
  CHECK(m.drive_profile == static_cast<int>(s.drive_profile));
}

/// Every field of two records that servo_state_t carries.
inline void check_state(const servo::CycleRecord& s, const servo::CycleRecord& r) {
  CHECK(r.utime == s.utime);
  CHECK(r.cycle == s.cycle);
  CHECK(r.t_s == s.t_s);
  CHECK(r.r_m == s.r_m);
  CHECK(r.r_dot_m_per_s == s.r_dot_m_per_s);
  CHECK(r.r_ddot_m_per_s2 == s.r_ddot_m_per_s2);
  CHECK(r.y_m == s.y_m);
  CHECK(r.e_m == s.e_m);
  CHECK(r.F_star_N == s.F_star_N);
  CHECK(r.u_fb_N == s.u_fb_N);
  CHECK(r.u_ff_N == s.u_ff_N);
  CHECK(r.Fy_star_N == s.Fy_star_N);
  CHECK(r.Fx_star_N == s.Fx_star_N);
  CHECK(r.Tz_star_Nm == s.Tz_star_Nm);
  CHECK(r.Fy_N == s.Fy_N);
  CHECK(r.Fx_N == s.Fx_N);
  CHECK(r.Tz_Nm == s.Tz_Nm);
  CHECK(r.commutation == s.commutation);
  CHECK(r.coil_set == s.coil_set);
  CHECK(r.delta_rad == s.delta_rad);
  REQUIRE(r.coil_sets == s.coil_sets);
  for (std::size_t l = 0; l < static_cast<std::size_t>(s.coil_sets); ++l) {
    CHECK(r.magnitude_N[l] == s.magnitude_N[l]);
    CHECK(r.setpoint_delta_rad[l] == s.setpoint_delta_rad[l]);
    CHECK(r.ia_A[l] == s.ia_A[l]);
    CHECK(r.ib_A[l] == s.ib_A[l]);
  }
  CHECK(r.damping_engaged == s.damping_engaged);
  CHECK(r.current_square_sum_A2 == s.current_square_sum_A2);
  CHECK(r.force_limited == s.force_limited);
  CHECK(r.state == s.state);
  CHECK(r.program_running == s.program_running);
  CHECK(r.program_time_s == s.program_time_s);
  CHECK(r.drive_profile == s.drive_profile);
}

inline telemetry::ServoStatusSample make_status() {
  telemetry::ServoStatusSample s;
  s.utime = 1'700'000'000'123'456;
  s.state = 2;
  s.fault = 203;
  s.fault_reason.assign("following error 1.2 mm above the 1 mm limit");
  s.fault_cycle = 123456;
  s.commutation = 2;
  s.axis.assign("stage-x");
  s.session = 0x1234abcd5678;
  s.calibration.path.assign("/var/lib/clm-servo/calibration.yaml");
  s.calibration.sha256.assign(std::string(64, 'a'));
  s.pgnn_model.path.assign("/var/lib/clm-servo/model-pgnn.yaml");
  s.pgnn_model.sha256.assign(std::string(64, 'b'));
  s.spline_model.path.assign("/var/lib/clm-servo/model-spline.yaml");
  s.spline_model.sha256.assign(std::string(64, 'c'));
  s.feedforward.path.assign("/var/lib/clm-servo/feedforward.yaml");
  s.feedforward.sha256.assign(std::string(64, 'd'));
  s.configuration.path.assign("/etc/clm-servo/servod.yaml");
  s.configuration.sha256.assign(std::string(64, 'e'));
  s.motor.path.assign("/etc/clm-servo/motor.yaml");
  s.motor.sha256.assign(std::string(64, 'f'));
  s.commands = {77, 1.5, 101, 1, 2, 3, 4, 5, 6, 7, 8};
  s.wakeup_latency_p50_s = 11e-6;
  s.wakeup_latency_p99_s = 23e-6;
  s.wakeup_latency_max_s = 47e-6;
  s.compute_time_p50_s = 13e-6;
  s.compute_time_p99_s = 29e-6;
  s.compute_time_max_s = 53e-6;
  s.overruns = 3;
  s.cycles = 1000001;
  for (std::size_t j = 0; j < s.wakeup_latency_histogram.size(); ++j) {
    s.wakeup_latency_histogram[j] = static_cast<std::int64_t>(3 * j + 1);
    s.compute_time_histogram[j] = static_cast<std::int64_t>(1000 - j);
  }
  s.frames_sent = 3000003;
  s.frames_received = 2000002;
  s.frames_missing = 5;
  s.frames_late = 7;
  s.frames_rejected = 11;
  s.bus_state = 1;
  s.damping_cycles = 13;
  s.program_running = true;
  s.program_time_s = 2.75;
  return s;
}

inline void check_status(const telemetry::ServoStatusSample& s, const clm_lcm::servo_status_t& m) {
  CHECK(m.utime == s.utime);
  CHECK(m.state == s.state);
  CHECK(m.fault == s.fault);
  CHECK(m.fault_reason == s.fault_reason.view());
  CHECK(m.fault_cycle == s.fault_cycle);
  CHECK(m.commutation == static_cast<int>(s.commutation));
  CHECK(m.axis == s.axis.view());
  CHECK(m.session == s.session);
  CHECK(m.calibration_file == s.calibration.path.view());
  CHECK(m.calibration_sha256 == s.calibration.sha256.view());
  CHECK(m.pgnn_model_file == s.pgnn_model.path.view());
  CHECK(m.pgnn_model_sha256 == s.pgnn_model.sha256.view());
  CHECK(m.spline_model_file == s.spline_model.path.view());
  CHECK(m.spline_model_sha256 == s.spline_model.sha256.view());
  CHECK(m.feedforward_file == s.feedforward.path.view());
  CHECK(m.feedforward_sha256 == s.feedforward.sha256.view());
  CHECK(m.configuration_file == s.configuration.path.view());
  CHECK(m.configuration_sha256 == s.configuration.sha256.view());
  CHECK(m.motor_file == s.motor.path.view());
  CHECK(m.motor_sha256 == s.motor.sha256.view());
  CHECK(m.control_client == s.commands.control_client);
  CHECK(m.control_lease_remaining_s == s.commands.control_lease_remaining_s);
  CHECK(m.commands_admitted == s.commands.admitted);
  CHECK(m.commands_refused_malformed == s.commands.refused_malformed);
  CHECK(m.commands_refused_other_axis == s.commands.refused_other_axis);
  CHECK(m.commands_refused_other_session == s.commands.refused_other_session);
  CHECK(m.commands_refused_no_client == s.commands.refused_no_client);
  CHECK(m.commands_refused_replayed == s.commands.refused_replayed);
  CHECK(m.commands_refused_stale == s.commands.refused_stale);
  CHECK(m.commands_refused_not_in_control == s.commands.refused_not_in_control);
  CHECK(m.commands_refused_by_daemon == s.commands.refused_by_daemon);
  CHECK(m.datagrams_dropped == s.commands.datagrams_dropped);
  CHECK(m.commands_refused_unauthenticated == s.commands.refused_unauthenticated);
  CHECK(m.wakeup_latency_p50_s == s.wakeup_latency_p50_s);
  CHECK(m.wakeup_latency_p99_s == s.wakeup_latency_p99_s);
  CHECK(m.wakeup_latency_max_s == s.wakeup_latency_max_s);
  CHECK(m.compute_time_p50_s == s.compute_time_p50_s);
  CHECK(m.compute_time_p99_s == s.compute_time_p99_s);
  CHECK(m.compute_time_max_s == s.compute_time_max_s);
  CHECK(m.overruns == s.overruns);
  CHECK(m.cycles == s.cycles);
  for (std::size_t j = 0; j < s.wakeup_latency_histogram.size(); ++j) {
    CHECK(m.wakeup_latency_histogram[j] == s.wakeup_latency_histogram[j]);
    CHECK(m.compute_time_histogram[j] == s.compute_time_histogram[j]);
  }
  CHECK(m.frames_sent == s.frames_sent);
  CHECK(m.frames_received == s.frames_received);
  CHECK(m.frames_missing == s.frames_missing);
  CHECK(m.frames_late == s.frames_late);
  CHECK(m.frames_rejected == s.frames_rejected);
  CHECK(m.bus_state == s.bus_state);
  CHECK(m.damping_cycles == s.damping_cycles);
  CHECK(static_cast<bool>(m.program_running) == s.program_running);
  CHECK(m.program_time_s == s.program_time_s);
}

}  // namespace clm::test
