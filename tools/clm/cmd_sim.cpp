// clm sim --can IFACE: the simulated motor as the drive and force-sensor
// nodes on a SocketCAN bus, for hardware-in-the-loop runs of clm-servod over
// vcan (docs/hil.md). The nodes' logic is clm::simbus::SimulatedNodes, the
// same the daemon's in-process bus uses: on each SYNC the motor steps one
// period, the encoder and force sensor are sampled and both TPDO1s go out;
// the setpoint RPDOs of a cycle are applied once all of them are in.
//
// Runs until SIGINT/SIGTERM or --duration-s, then prints one summary line on
// stdout. Exit status: 0 after a clean stop, 2 on bad input or when the bus
// cannot be opened (e.g. a kernel without SocketCAN), with one line on stderr.
#include <signal.h>
#include <time.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "daemon/simbus/simulated_nodes.hpp"
#include "drivers/socket_can_bus.hpp"
#include "tools/clm/commands.hpp"
#include "tools/sim/motor.hpp"
#include "tools/sim/motor_file.hpp"

namespace clm::cli {
namespace {

std::atomic<int> g_stop_signal{0};

extern "C" void on_stop_signal(int signal) { g_stop_signal.store(signal, std::memory_order_relaxed); }

std::int64_t monotonic_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

struct SimOptions {
  std::string interface_name;
  std::string motor_file;
  double rate_hz = 1000.0;
  double duration_s = 0.0;  ///< 0: until a signal
  int drive_node_id = 1;
  int force_sensor_node_id = 2;
};

/// Longest a receive waits, so a signal or the end of the duration is seen
/// within this time even on a silent bus [ns].
constexpr std::int64_t kMaxWait_ns = 50'000'000;

void run_sim(const SimOptions& options) {
  const sim::MotorParameters parameters = sim::load_motor_parameters(options.motor_file);
  sim::SimulatedMotor motor(parameters);

  can::ProtocolConfig protocol;
  protocol.drive_node_id = static_cast<std::uint8_t>(options.drive_node_id);
  protocol.force_sensor_node_id = static_cast<std::uint8_t>(options.force_sensor_node_id);
  protocol.coil_sets = motor.coil_sets();
  protocol.validate();
  const double period_s = 1.0 / options.rate_hz;
  simbus::SimulatedNodes nodes(motor, protocol, period_s);

  // The nodes hear SYNC and the drive's RPDOs for this L, nothing else.
  std::vector<std::uint32_t> receive_ids{can::kSyncId};
  for (std::size_t k = 0; k < can::setpoint_frame_count(protocol.coil_sets); ++k) {
    receive_ids.push_back(can::setpoint_id(protocol, k));
  }
  drivers::SocketCanBus bus(options.interface_name, receive_ids);

  // An asynchronous handler that only sets a flag; without SA_RESTART, so a
  // wait in ppoll returns and the loop sees the flag at once.
  struct sigaction action{};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);

  std::fprintf(stderr, "clm sim: %s: %d coil sets, drive node %d, force sensor node %d, %g Hz; waiting for SYNC\n",
               options.interface_name.c_str(), protocol.coil_sets, options.drive_node_id, options.force_sensor_node_id,
               options.rate_hz);

  const std::int64_t start_ns = monotonic_ns();
  const std::int64_t end_ns =
      options.duration_s > 0.0 ? start_ns + static_cast<std::int64_t>(options.duration_s * 1e9) : INT64_MAX;
  std::int64_t replies_sent = 0, replies_failed = 0;
  std::array<can::Frame, 2> replies{};
  drivers::ReceivedFrame received;
  while (g_stop_signal.load(std::memory_order_relaxed) == 0) {
    const std::int64_t now_ns = monotonic_ns();
    if (now_ns >= end_ns) break;
    if (!bus.receive(received, std::min(end_ns, now_ns + kMaxWait_ns))) continue;
    const std::size_t count = nodes.on_frame(received.frame, replies);
    for (std::size_t k = 0; k < count; ++k) {
      if (bus.send(replies[k])) {
        ++replies_sent;
      } else {
        ++replies_failed;
      }
    }
  }
  const double elapsed_s = static_cast<double>(monotonic_ns() - start_ns) * 1e-9;

  const int signal = g_stop_signal.load(std::memory_order_relaxed);
  const std::string why = signal == SIGINT ? "SIGINT" : signal == SIGTERM ? "SIGTERM" : "end of --duration-s";
  const simbus::NodeCounters& c = nodes.counters();
  const sim::TruthState truth = motor.truth();
  std::printf("clm sim: stopped on %s after %.1f s on %s: %lld SYNCs, %lld setpoint sets applied, %lld frames rejected, "
              "%lld feedback values not encodable, %lld replies sent, %lld not sent, %llu error frames, %llu dropped; "
              "position %.6f m, drive %s%s\n",
              why.c_str(), elapsed_s, options.interface_name.c_str(), static_cast<long long>(c.syncs),
              static_cast<long long>(c.setpoints_applied), static_cast<long long>(c.frames_rejected),
              static_cast<long long>(c.feedback_not_encoded), static_cast<long long>(replies_sent),
              static_cast<long long>(replies_failed), static_cast<unsigned long long>(bus.error_frames()),
              static_cast<unsigned long long>(bus.dropped_frames()), truth.position_m,
              motor.status().enabled() ? "enabled" : "disabled", motor.status().fault() ? ", fault latched" : "");
  std::fflush(stdout);
}

}  // namespace

void add_sim(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "sim", "run the simulated motor as the drive and force-sensor CAN nodes on a SocketCAN interface (docs/hil.md)");
  auto options = std::make_shared<SimOptions>();
  sub->add_option("--can", options->interface_name, "SocketCAN interface, e.g. vcan0")->required();
  sub->add_option("--motor", options->motor_file, "simulated motor file (config/motor-sim.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--rate-hz", options->rate_hz, "SYNC rate of the daemon: the motor steps 1/rate per SYNC [Hz]")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->add_option("--duration-s", options->duration_s, "stop after this many seconds [s]; default: until SIGINT/SIGTERM")
      ->check(CLI::PositiveNumber);
  sub->add_option("--drive-node-id", options->drive_node_id, "CANopen node ID of the drive (the daemon's can.drive_node_id)")
      ->check(CLI::Range(1, 127))
      ->capture_default_str();
  sub->add_option("--force-sensor-node-id", options->force_sensor_node_id,
                  "CANopen node ID of the force sensor (the daemon's can.force_sensor_node_id)")
      ->check(CLI::Range(1, 127))
      ->capture_default_str();
  sub->callback([options] {
    if (!std::isfinite(options->rate_hz)) throw std::runtime_error("--rate-hz must be finite");
    run_sim(*options);
  });
}

}  // namespace clm::cli
