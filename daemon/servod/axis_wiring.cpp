#include "daemon/servod/axis_wiring.hpp"

#include <stdexcept>
#include <string>
#include <utility>

#include "drivers/sim/motor_file.hpp"
#include "drivers/socket_can_bus.hpp"

namespace clm::servod {

std::vector<ExtraLaw> AxisWiring::extra_laws() const {
  std::vector<ExtraLaw> laws;
  if (oracle) laws.push_back({servo::CommutationMode::kOracle, oracle.get(), "simulator truth"});
  return laws;
}

AxisWiring wire_simulated_axis(const ServodConfig& config, const sim::MotorParameters& parameters) {
  AxisWiring wiring;
  wiring.motor = std::make_unique<sim::SimulatedMotor>(parameters);
  if (wiring.motor->coil_sets() != config.motor.coil_sets) {
    throw std::runtime_error(config.motor_file + ": simulated motor has " + std::to_string(wiring.motor->coil_sets()) +
                             " coil sets, motor.coil_sets says " + std::to_string(config.motor.coil_sets));
  }
  if (parameters.sensors.encoder_power_up_offset_max_m > 0.0 && !config.servo.homing.incremental()) {
    // An encoder that powers up at an unknown offset, on an axis that never homes.
    throw std::runtime_error(config.motor_file + ": simulation.sensors.encoder_power_up_offset_max_m " +
                             std::to_string(parameters.sensors.encoder_power_up_offset_max_m) +
                             " m makes the encoder incremental, but " + config.origin +
                             " says homing.method none (an absolute encoder)");
  }
  wiring.nodes = std::make_unique<sim::SimulatedNodes>(*wiring.motor, config.servo.protocol, config.servo.period_s);
  auto bus = std::make_unique<sim::InProcessBus>(*wiring.nodes);
  wiring.in_process_bus = bus.get();
  bus->set_plan(config.can.sim_fault_plan);
  wiring.clock = bus.get();
  wiring.bus = std::move(bus);
  wiring.oracle = std::make_unique<sim::OracleCommutator>(wiring.motor->electromagnetics(), config.motor.drive,
                                                          config.commutation.options);
  return wiring;
}

AxisWiring wire_axis(const ServodConfig& config) {
  if (config.can.bus == BusKind::kSimulated) {
    return wire_simulated_axis(config, sim::load_motor_parameters(config.motor_file));
  }
  AxisWiring wiring;
  const auto ids = can::daemon_receive_ids(config.servo.protocol);
  wiring.bus = std::make_unique<drivers::SocketCanBus>(config.can.interface,
                                                       std::vector<std::uint32_t>(ids.view().begin(), ids.view().end()));
  return wiring;
}

WiredAxis::WiredAxis(const ServodConfig& config) : WiredAxis(config, wire_axis(config)) {}

WiredAxis::WiredAxis(const ServodConfig& config, AxisWiring given_wiring)
    : wiring(std::move(given_wiring)), daemon(config, *wiring.bus, *wiring.clock, wiring.extra_laws()) {}

}  // namespace clm::servod
