#pragma once
// What the daemon of one axis talks to, chosen from the configuration's
// can.bus (which the configuration reader decided from can.interface), in
// one place for every builder (clm-servod, the commissioning, tests):
//   kSimulated  the embedded simulated motor (motor_file) as the drive and
//               force-sensor nodes on an in-process bus, which is also the
//               bus's clock, and the oracle commutation on the motor's truth;
//   kSocketCan  the SocketCAN interface can.interface; no clock (the
//               hardware keeps its own time), no extra law.

#include <memory>
#include <vector>

#include "daemon/servod/servo_daemon.hpp"
#include "daemon/servod/servod_config.hpp"
#include "drivers/bus_clock.hpp"
#include "drivers/can_bus.hpp"
#include "drivers/sim/in_process_bus.hpp"
#include "drivers/sim/motor.hpp"
#include "drivers/sim/oracle.hpp"
#include "drivers/sim/parameters.hpp"
#include "drivers/sim/simulated_nodes.hpp"

namespace clm::servod {

/// The bus of one axis and, on the simulator, what is behind it. Movable;
/// must outlive the daemon built on it.
struct AxisWiring {
  std::unique_ptr<sim::SimulatedMotor> motor;  ///< the simulated motor, null on a real bus
  std::unique_ptr<sim::SimulatedNodes> nodes;  ///< its CAN nodes, null on a real bus
  std::unique_ptr<drivers::CanBus> bus;        ///< the daemon's bus, never null
  /// The same bus as `bus` when it is the in-process one (fault injection,
  /// bus monitor), else null.
  sim::InProcessBus* in_process_bus = nullptr;
  drivers::BusClock* clock = &drivers::no_bus_clock();  ///< the bus's time base, never null
  std::unique_ptr<sim::OracleCommutator> oracle;        ///< on the motor's truth, null on a real bus

  /// The laws to offer beside the configuration's: the oracle on the simulator.
  std::vector<ExtraLaw> extra_laws() const;
};

/// Builds the wiring `config` names. Throws std::runtime_error naming the
/// motor file when the simulated motor's coil-set count differs from
/// motor.coil_sets, what sim::load_motor_parameters throws for a bad motor
/// file, and what drivers::SocketCanBus throws when the interface cannot be opened.
AxisWiring wire_axis(const ServodConfig& config);

/// The simulated wiring of `config` (as wire_axis builds it for
/// BusKind::kSimulated) on a motor with `parameters` instead of those of
/// config.motor_file: the same daemon on a motor of another seed or with
/// ideal sensors (tests, studies). Throws std::runtime_error naming the motor
/// file when the coil-set count differs from motor.coil_sets.
AxisWiring wire_simulated_axis(const ServodConfig& config, const sim::MotorParameters& parameters);

/// A daemon on the wiring its configuration names, owned together (the
/// wiring is built first and goes last). Not movable.
struct WiredAxis {
  /// Throws what wire_axis and the ServoDaemon constructor throw.
  explicit WiredAxis(const ServodConfig& config);
  /// The daemon on a wiring built by the caller (wire_simulated_axis), which
  /// must be the one `config` describes. Throws what the ServoDaemon constructor throws.
  WiredAxis(const ServodConfig& config, AxisWiring given_wiring);

  AxisWiring wiring;
  ServoDaemon daemon;

  /// The simulated motor, or nullptr on a real bus.
  sim::SimulatedMotor* simulated_motor() noexcept { return wiring.motor.get(); }
  /// The in-process bus, or nullptr on a real bus.
  sim::InProcessBus* in_process_bus() noexcept { return wiring.in_process_bus; }
};

}  // namespace clm::servod
