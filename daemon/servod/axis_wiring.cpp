#include "daemon/servod/axis_wiring.hpp"

#include <stdexcept>
#include <string>

#include "drivers/sim/motor_file.hpp"
#include "drivers/socket_can_bus.hpp"

namespace clm::servod {

std::vector<ExtraLaw> AxisWiring::extra_laws() const {
  std::vector<ExtraLaw> laws;
  if (oracle) laws.push_back({servo::CommutationMode::kOracle, oracle.get(), "simulator truth"});
  return laws;
}

AxisWiring wire_axis(const ServodConfig& config) {
  AxisWiring wiring;
  const auto& protocol = config.servo.protocol;
  if (config.can.interface == "sim") {
    wiring.motor = std::make_unique<sim::SimulatedMotor>(sim::load_motor_parameters(config.motor_file));
    if (wiring.motor->coil_sets() != config.motor.coil_sets) {
      throw std::runtime_error(config.motor_file + ": simulated motor has " + std::to_string(wiring.motor->coil_sets()) +
                               " coil sets, motor.coil_sets says " + std::to_string(config.motor.coil_sets));
    }
    wiring.nodes = std::make_unique<sim::SimulatedNodes>(*wiring.motor, protocol, config.servo.period_s);
    auto bus = std::make_unique<sim::InProcessBus>(*wiring.nodes);
    wiring.in_process_bus = bus.get();
    bus->set_plan(config.can.sim_fault_plan);
    wiring.clock = bus.get();
    wiring.bus = std::move(bus);
    wiring.oracle = std::make_unique<sim::OracleCommutator>(wiring.motor->electromagnetics(), config.motor.drive,
                                                            config.commutation.options);
  } else {
    const auto ids = can::daemon_receive_ids(protocol);
    wiring.bus = std::make_unique<drivers::SocketCanBus>(config.can.interface,
                                                         std::vector<std::uint32_t>(ids.view().begin(), ids.view().end()));
  }
  return wiring;
}

WiredAxis::WiredAxis(const ServodConfig& config)
    : wiring(wire_axis(config)), daemon(config, *wiring.bus, *wiring.clock, wiring.extra_laws()) {}

}  // namespace clm::servod
