// clm ctl: talks to a running clm-servod over LCM (docs/servod.md) through
// the servod_client. `status` waits for one CLM_SERVO_STATUS; every other
// subcommand publishes one servo_command_t for the axis and session a status
// names (--axis chooses among several axes), as this user's client id
// (--client-id overrides), with a fresh sequence number, on
// CLM_SERVO_COMMAND and waits for the CLM_SERVO_COMMAND_ACK with that axis,
// session, client and sequence. A command that needs control is preceded by
// TAKE_CONTROL unless the status shows this client holding it with more than
// 1 s left; stop and disable never take control; `release` gives it up
// (docs/servod.md "Command authority"). `status` prints --axis's status, or
// the first one heard, and the axis's motion from the states that follow it;
// `watch` prints it again and again.
//
// Exit status (config/exit_status.hpp): 0 status received / command
// accepted (the ack's text on stdout); 1 no answer within --timeout-s,
// command refused (the ack's text as the one stderr line "clm ctl: error:
// ..."), or LCM not available; 2 bad arguments, or several axes answering
// without --axis.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "clm_lcm/servo_command_t.hpp"
#include "clm_lcm/servo_state_t.hpp"
#include "clm_lcm/servo_status_t.hpp"
#include "config/command_line.hpp"
#include "daemon/telemetry/telemetry.hpp"
#include "tools/cli/commands.hpp"
#include "tools/cli/ctl_support.hpp"
#include "tools/servod_client/client.hpp"
#include "tools/servod_client/stop_signals.hpp"

namespace clm::cli {
namespace {

using servod_client::make_command;


const char* state_name(int state) {
  switch (state) {
    case clm_lcm::servo_status_t::STATE_DISABLED: return "disabled";
    case clm_lcm::servo_status_t::STATE_ENABLED: return "enabled";
    case clm_lcm::servo_status_t::STATE_FAULT: return "fault";
    default: return "unknown";
  }
}

const char* commutation_name(int mode) {
  static const char* const names[] = {"original", "classical", "pgnn", "spline", "oracle", "experiment"};
  return mode >= 0 && mode < 6 ? names[mode] : "unknown";
}

const char* bus_state_name(int state) {
  switch (state) {
    case clm_lcm::servo_status_t::BUS_STATE_NONE: return "none";
    case clm_lcm::servo_status_t::BUS_STATE_ERROR_ACTIVE: return "error-active";
    case clm_lcm::servo_status_t::BUS_STATE_ERROR_WARNING: return "error-warning";
    case clm_lcm::servo_status_t::BUS_STATE_ERROR_PASSIVE: return "error-passive";
    case clm_lcm::servo_status_t::BUS_STATE_BUS_OFF: return "bus-off";
    default: return "unknown";
  }
}

/// One `field: value` line per servo_status_t field, the field names as in
/// lcmtypes/servo_status_t.lcm, so scripts can pick lines out.
void print_status(const clm_lcm::servo_status_t& s) {
  std::printf("axis: %s\n", s.axis.c_str());
  std::printf("session: %lld\n", static_cast<long long>(s.session));
  std::printf("state: %s\n", state_name(s.state));
  std::printf("fault: %d\n", s.fault);
  std::printf("fault_reason: %s\n", s.fault_reason.c_str());
  std::printf("fault_cycle: %lld\n", static_cast<long long>(s.fault_cycle));
  std::printf("commutation: %s\n", commutation_name(s.commutation));
  const auto file = [](const char* name, const std::string& path, const std::string& sha256) {
    std::printf("%s: %s%s%s\n", name, path.c_str(), sha256.empty() ? "" : " sha256 ", sha256.c_str());
  };
  file("calibration_file", s.calibration_file, s.calibration_sha256);
  file("pgnn_model_file", s.pgnn_model_file, s.pgnn_model_sha256);
  file("spline_model_file", s.spline_model_file, s.spline_model_sha256);
  file("feedforward_file", s.feedforward_file, s.feedforward_sha256);
  std::printf("program_running: %s\n", s.program_running ? "true" : "false");
  std::printf("program_time_s: %.3f\n", s.program_time_s);
  std::printf("restricted: %s\n", s.restricted ? "true" : "false");
  static constexpr const char* kForceSensor[] = {"none", "ok", "lost"};
  std::printf("force_sensor: %s", kForceSensor[s.force_sensor]);
  if (s.force_sensor == clm_lcm::servo_status_t::FORCE_SENSOR_LOST) std::printf(" (%d)", s.force_sensor_warning);
  std::printf(", losses %lld\n", static_cast<long long>(s.force_sensor_losses));
  std::printf("drive:%s%s%s%s%s%s, current limited %lld cycles\n",
              s.enabling ? " enabling (waiting for the drive to report enabled):" : "",
              (s.drive_signals & clm_lcm::servo_status_t::DRIVE_ENABLED) ? " enabled" : " not enabled",
              (s.drive_signals & clm_lcm::servo_status_t::DRIVE_FAULT) ? " fault" : "",
              (s.drive_signals & clm_lcm::servo_status_t::DRIVE_WATCHDOG_EXPIRED) ? " watchdog-expired" : "",
              (s.drive_signals & clm_lcm::servo_status_t::DRIVE_CURRENT_LIMITED) ? " current-limited" : "",
              (s.drive_signals & clm_lcm::servo_status_t::DRIVE_END_STOP) ? " end-stop" : "",
              static_cast<long long>(s.current_limited_cycles));
  static constexpr const char* kHoming[] = {"idle", "finding commutation", "searching the reference",
                                            "stopping at the reference", "backing off the hard stop",
                                            "leaving the reference switch"};
  const bool known_phase = s.homing >= 0 && s.homing < static_cast<int>(std::size(kHoming));
  std::printf("homing: %s, commutation %s, %s", known_phase ? kHoming[s.homing] : "unknown phase",
              s.commutation_found ? "found" : "unknown",
              s.homed ? "homed" : "not homed (positions are the encoder's reading)");
  if (s.commutation_found) std::printf(", found phase %.4f rad", s.found_phase_rad);
  if (s.homed) std::printf(", axis offset %.9f m", s.axis_offset_m);
  std::printf("\n");
  std::printf("cycles: %lld\n", static_cast<long long>(s.cycles));
  std::printf("overruns: %lld\n", static_cast<long long>(s.overruns));
  std::printf("wakeup_latency_s: p50 %.1e, p99 %.1e, max %.1e\n", s.wakeup_latency_p50_s, s.wakeup_latency_p99_s,
              s.wakeup_latency_max_s);
  std::printf("compute_time_s: p50 %.1e, p99 %.1e, max %.1e\n", s.compute_time_p50_s, s.compute_time_p99_s,
              s.compute_time_max_s);
  std::printf("frames: sent %lld, received %lld, missing %lld, late %lld, rejected %lld\n",
              static_cast<long long>(s.frames_sent), static_cast<long long>(s.frames_received),
              static_cast<long long>(s.frames_missing), static_cast<long long>(s.frames_late),
              static_cast<long long>(s.frames_rejected));
  std::printf("bus_state: %s\n", bus_state_name(s.bus_state));
  std::printf("damping_cycles: %lld\n", static_cast<long long>(s.damping_cycles));
  std::printf("telemetry_dropped: %lld\n", static_cast<long long>(s.telemetry_dropped));
  std::printf("control_client: %lld\n", static_cast<long long>(s.control_client));
  std::printf("control_lease_remaining_s: %.1f\n", s.control_lease_remaining_s);
  std::printf("commands: admitted %lld, refused malformed %lld, other_axis %lld, other_session %lld, no_client %lld, "
              "replayed %lld, stale %lld, not_in_control %lld, by_daemon %lld, unauthenticated %lld, datagrams_dropped %lld\n",
              static_cast<long long>(s.commands_admitted), static_cast<long long>(s.commands_refused_malformed),
              static_cast<long long>(s.commands_refused_other_axis),
              static_cast<long long>(s.commands_refused_other_session),
              static_cast<long long>(s.commands_refused_no_client), static_cast<long long>(s.commands_refused_replayed),
              static_cast<long long>(s.commands_refused_stale), static_cast<long long>(s.commands_refused_not_in_control),
              static_cast<long long>(s.commands_refused_by_daemon),
              static_cast<long long>(s.commands_refused_unauthenticated), static_cast<long long>(s.datagrams_dropped));
}

/// The axis in motion, from the CLM_SERVO_STATE messages of a short window
/// (signed, as the status): position, velocity (Δy/Δt across the window),
/// following error, force demand; and how long ago a latched fault latched.
/// States name no axis: with several daemons on one URL they may be another's.
void print_motion(const clm_lcm::servo_status_t& status, const std::vector<clm_lcm::servo_state_t>& states) {
  if (states.empty()) {
    std::printf("position_m: unknown (no CLM_SERVO_STATE came; telemetry.state_decimation too high?)\n");
    return;
  }
  const clm_lcm::servo_state_t& last = states.back();
  const clm_lcm::servo_state_t& first = states.front();
  std::printf("position_m: %.9f\n", last.y_m);
  if (last.t_s > first.t_s) {
    std::printf("velocity_m_per_s: %.6f (over %.3f s)\n", (last.y_m - first.y_m) / (last.t_s - first.t_s),
                last.t_s - first.t_s);
  } else {
    std::printf("velocity_m_per_s: unknown (one state)\n");
  }
  std::printf("reference_m: %.9f\n", last.r_m);
  std::printf("following_error_m: %.3e\n", last.e_m);
  std::printf("force_demand_N: %.3f%s\n", last.F_star_N, last.force_limited ? " (at control.force_limit_N)" : "");
  if (status.fault != 0 && status.fault_cycle >= 0 && last.cycle > 0) {
    const double period_s = last.t_s / static_cast<double>(last.cycle);
    std::printf("fault_latched_s_ago: %.1f\n", static_cast<double>(last.cycle - status.fault_cycle) * period_s);
  }
}

/// One status and the motion of the states that follow it.
void show_status(servod_client::Client& client, const CtlOptions& options) {
  const clm_lcm::servo_status_t status = client.wait_for_status(options.timeout_s);
  client.start_capture();
  const std::int64_t before = client.states_received();
  const auto start = std::chrono::steady_clock::now();
  const auto waited = [&] { return std::chrono::steady_clock::now() - start; };
  // 20 ms of states, at least two of them, within the timeout.
  while (waited() < std::chrono::duration<double>(options.timeout_s) &&
         (client.states_received() - before < 2 || waited() < std::chrono::milliseconds(20))) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::vector<clm_lcm::servo_state_t> states;
  for (const auto& message : client.stop_capture()) {
    clm_lcm::servo_state_t state;
    if (message.channel == telemetry::kStateChannel && servod_client::decode(message.data, state)) states.push_back(state);
  }
  print_status(status);
  print_motion(status, states);
}

void run_status(const CtlOptions& options, int count, double every_s) {
  servod_client::Client client(
      client_options(options, std::string("(") + telemetry::kStatusChannel + "|" + telemetry::kStateChannel + ")"));
  if (count != 1) servod_client::install_stop_signals();
  try {
    // Only reading: the first axis heard (or --axis's), without listening for others.
    client.target(options.timeout_s, false);
    for (int shown = 0; count == 0 || shown < count; ++shown) {
      if (shown > 0) std::this_thread::sleep_for(std::chrono::duration<double>(every_s));
      if (servod_client::stop_signal() != 0) break;
      if (count != 1) std::printf("---\n");
      show_status(client, options);
      std::fflush(stdout);
    }
  } catch (const servod_client::SeveralAxes& e) {
    several_axes(e);
  }
}

}  // namespace

void add_ctl(CLI::App& app) {
  auto* ctl = app.add_subcommand("ctl", "control a running clm-servod over LCM: status and commands");
  ctl->require_subcommand(1);
  ctl->fallthrough();  // --lcm-url and --timeout-s also after the subcommand
  auto options = std::make_shared<CtlOptions>();
  options->lcm_url = servod_client::default_lcm_url();
  ctl->add_option("--lcm-url", options->lcm_url,
                  "LCM URL of the daemon (its telemetry.lcm_url); default: $CLM_SERVO_LCM_URL, else the shipped one")
      ->capture_default_str();
  ctl->add_option("--timeout-s", options->timeout_s, "how long to wait for the status or the ack [s]")
      ->check(clm::positive_number())
      ->capture_default_str();
  ctl->add_option("--axis", options->axis,
                  "the axis to command or report (servo_status_t.axis); default: the only one answering");
  ctl->add_option("--client-id", options->client_id,
                  "client id the commands carry; default: FNV-1a-64 of \"UID@HOSTNAME\", the same for every clm ctl of the user")
      ->check(clm::at_least(1));
  ctl->add_option("--key-file", options->key_file,
                  "the operators' key shared with the daemon (its commands.key_file); default: $CLM_SERVO_KEY_FILE, "
                  "else /etc/clm-servo/command.key");

  ctl->add_subcommand("status", "print the daemon's status and the axis's motion (position, velocity, following "
                                "error, force demand) from its signed telemetry")
      ->callback([options] { run_status(*options, 1, 0.0); });
  struct WatchOptions {
    int count = 0;
    double every_s = 0.5;
  };
  auto watch = std::make_shared<WatchOptions>();
  auto* watch_sub = ctl->add_subcommand("watch", "print the status again and again, each after a line '---', until "
                                                 "SIGINT or --count");
  watch_sub->add_option("--count", watch->count, "how many times (0: until interrupted)")
      ->check(clm::at_least(0))->capture_default_str();
  watch_sub->add_option("--every-s", watch->every_s, "time between two [s]")
      ->check(clm::in_range(0.1, 3600.0))->capture_default_str();
  watch_sub->callback([options, watch] { run_status(*options, watch->count, watch->every_s); });

  const auto simple = [&](const char* name, Kind kind, const char* help) {
    ctl->add_subcommand(name, help)->callback([options, kind] { send_command(*options, make_command(kind)); });
  };
  simple("enable", Kind::kEnable, "close the loop at the present position");
  simple("disable", Kind::kDisable, "open the loop, drives off");
  simple("clear-fault", Kind::kClearFault, "leave the fault state (to disabled)");
  simple("stop", Kind::kStop, "stop the running motion (jerk-limited), stay enabled");
  simple("take-control", Kind::kTakeControl, "become the client that commands the axis (other commands do it themselves)");
  simple("release", Kind::kReleaseControl, "give up control of the axis");
  simple("quick-stop", Kind::kQuickStop, "stop the running motion within the quick-stop limits, stay enabled");
  simple("home", Kind::kHome,
         "enable if needed, find the commutation where unknown, search the reference (homing:), stay enabled");

  struct MoveOptions {
    double target_m = 0.0, velocity_m_per_s = 0.1, acceleration_m_per_s2 = 1.0, jerk_m_per_s3 = 1000.0;
  };
  auto move = std::make_shared<MoveOptions>();
  auto* move_to = ctl->add_subcommand("move-to", "jerk-limited move to a position");
  move_to->add_option("--target-m", move->target_m, "target position [m]")->required();
  move_to->add_option("--velocity-m-per-s", move->velocity_m_per_s, "velocity limit [m/s]")
      ->check(clm::positive_number())->capture_default_str();
  move_to->add_option("--acceleration-m-per-s2", move->acceleration_m_per_s2, "acceleration limit [m/s^2]")
      ->check(clm::positive_number())->capture_default_str();
  move_to->add_option("--jerk-m-per-s3", move->jerk_m_per_s3, "jerk limit [m/s^3]")
      ->check(clm::positive_number())->capture_default_str();
  move_to->callback([options, move] {
    if (!std::isfinite(move->target_m)) throw std::runtime_error("--target-m must be finite");
    Command command = make_command(Kind::kMoveTo);
    command.target_m = move->target_m;
    command.limits = {move->velocity_m_per_s, move->acceleration_m_per_s2, move->jerk_m_per_s3};
    send_command(*options, command);
  });

  struct JogOptions {
    double velocity_m_per_s = 0.0, acceleration_m_per_s2 = 1.0, jerk_m_per_s3 = 1000.0, duration_s = 1.0, repeat_s = 0.1;
  };
  auto jog = std::make_shared<JogOptions>();
  auto* jog_sub = ctl->add_subcommand(
      "jog", "move at a velocity for --duration-s by repeating JOG every --repeat-s; the daemon stops the axis when the "
             "repeats stop (motion.jog_timeout_s)");
  jog_sub->add_option("--velocity-m-per-s", jog->velocity_m_per_s, "velocity [m/s], signed: + towards the upper soft limit")
      ->required();
  jog_sub->add_option("--acceleration-m-per-s2", jog->acceleration_m_per_s2, "acceleration limit [m/s^2]")
      ->check(clm::positive_number())->capture_default_str();
  jog_sub->add_option("--jerk-m-per-s3", jog->jerk_m_per_s3, "jerk limit [m/s^3]")
      ->check(clm::positive_number())->capture_default_str();
  jog_sub->add_option("--duration-s", jog->duration_s, "how long to keep repeating [s]")
      ->check(clm::in_range(0.01, 3600.0))->capture_default_str();
  jog_sub->add_option("--repeat-s", jog->repeat_s, "time between repeats [s]; below the daemon's jog_timeout_s")
      ->check(clm::in_range(0.01, 1.0))->capture_default_str();
  jog_sub->callback([options, jog] {
    if (!std::isfinite(jog->velocity_m_per_s) || jog->velocity_m_per_s == 0.0) {
      throw std::runtime_error("--velocity-m-per-s must be finite and not 0 (its sign is the direction)");
    }
    servod_client::install_stop_signals();
    servod_client::Client client(command_client_options(*options));
    const auto start = std::chrono::steady_clock::now();
    const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(jog->repeat_s));
    int repeats = 0;
    for (auto next = start; std::chrono::steady_clock::now() - start < std::chrono::duration<double>(jog->duration_s);
         next += period) {
      if (servod_client::stop_signal() != 0) {
        // Stop the jog now rather than after the daemon's jog timeout, give control back, exit 1.
        client.stop_and_release(options->timeout_s);
        servod_client::throw_if_interrupted();
      }
      Command command = make_command(Kind::kJog);
      command.jog_velocity_m_per_s = jog->velocity_m_per_s;
      command.limits = {std::abs(jog->velocity_m_per_s), jog->acceleration_m_per_s2, jog->jerk_m_per_s3};
      const servod_client::Ack ack = send(client, *options, command);
      require_accepted(ack);
      if (repeats++ == 0) std::printf("%s\n", ack.text.c_str());
      std::this_thread::sleep_until(next + period);  // a signal is seen at the next repeat, --repeat-s at most
    }
    std::printf("jogged: %d repeats in %.2f s; the daemon stops the axis once no repeat has come for its jog_timeout_s\n",
                repeats, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  });

  const auto with_file = [&](const char* name, Kind kind, const char* help, const char* what) {
    auto file = std::make_shared<std::string>();
    auto* sub = ctl->add_subcommand(name, help);
    sub->add_option("FILE", *file, what)->required()->check(CLI::ExistingFile);
    sub->callback([options, file, kind] {
      Command command = make_command(kind);
      servod_client::assign_text(kind == Kind::kRunProgram ? command.program : command.path, absolute_path(*file),
                                 "FILE");
      send_command(*options, command);
    });
  };
  with_file("run-program", Kind::kRunProgram, "run a motion program file (config/programs/*.yaml)",
            "program file (format clm-servo-program)");
  with_file("load-calibration", Kind::kLoadCalibration, "load a calibration file into the classical law",
            "calibration file (clm calibrate)");
  with_file("load-model", Kind::kLoadModel, "load a model file into the pgnn or spline law (the file's kind:)",
            "model file (clm identify)");
  with_file("load-feedforward", Kind::kLoadFeedforward, "load a feedforward file: eq. (40)'s parameters, at once",
            "feedforward file (clm ff-identify)");

  auto mode = std::make_shared<std::string>();
  auto* commutation = ctl->add_subcommand("commutation", "switch the commutation law (at the next standstill)");
  commutation->add_option("MODE", *mode, "original | classical | pgnn | spline | oracle")
      ->required()
      ->check(CLI::IsMember({"original", "classical", "pgnn", "spline", "oracle"}));
  commutation->callback([options, mode] {
    Command command = make_command(Kind::kSetCommutation);
    for (int code = 0; code < servo::kCommutationModes; ++code) {
      const auto law = static_cast<servo::CommutationMode>(code);
      if (*mode == servo::name(law)) command.commutation = law;
    }
    send_command(*options, command);
  });

  struct ExperimentOptions {
    int coil_set = 0;
    double delta_rad = 0.0;
  };
  auto experiment = std::make_shared<ExperimentOptions>();
  auto* sub = ctl->add_subcommand("experiment", "identification experiment: drive one coil set with a phase offset");
  sub->add_option("--coil-set", experiment->coil_set, "coil set l = 1..L")->required()->check(clm::in_range(1, 8));
  sub->add_option("--delta-rad", experiment->delta_rad, "phase offset added to the drive's commutation angle [rad]")
      ->required();
  sub->callback([options, experiment] {
    if (!std::isfinite(experiment->delta_rad)) throw std::runtime_error("--delta-rad must be finite");
    Command command = make_command(Kind::kSetExperiment);
    command.coil_set = experiment->coil_set;
    command.delta_rad = experiment->delta_rad;
    send_command(*options, command);
  });
  add_ctl_parameters(*ctl, options);
}

}  // namespace clm::cli
