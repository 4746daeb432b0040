// The in-process bus's fault-injection plan (can.sim_fault_plan): parsing,
// each step firing at the SYNC after its request and acting for exactly its
// frames or cycles, and the disturbance force it uses on the motor.

#include <catch2/catch.hpp>
#include <cmath>

#include "drivers/sim/in_process_bus.hpp"
#include "drivers/sim/motor.hpp"
#include "drivers/sim/simulated_nodes.hpp"
#include "tests/drivers/sim/sim_support.hpp"

using clm::sim::PlannedFault;

namespace {

struct Bench {
  clm::sim::SimulatedMotor motor{clm::sim::fixtures::default_motor()};
  clm::can::ProtocolConfig protocol{1, 2, motor.coil_sets()};
  clm::sim::SimulatedNodes nodes{motor, protocol, 0.001};
  clm::sim::InProcessBus bus{nodes};
  std::uint8_t sync_counter = 1;

  /// Sends a SYNC; returns how many drive and force frames came back.
  std::pair<int, int> sync() {
    clm::can::Frame frame{};
    clm::can::encode_sync(sync_counter++, frame);
    bus.send(frame);
    int drive = 0, force = 0;
    clm::drivers::ReceivedFrame received;
    while (bus.receive(received, 0)) {
      if (received.frame.id == clm::can::drive_feedback_id(protocol)) ++drive;
      if (received.frame.id == clm::can::force_feedback_id(protocol)) ++force;
    }
    return {drive, force};
  }
};

}  // namespace

TEST_CASE("fault plans parse by name, count and value, and refuse anything else", "[sim][injection]") {
  const auto plan = clm::sim::parse_planned_faults("drop-drive:3,corrupt-alive,push:40:650.5,stall:8:0.0015,bus-off");
  REQUIRE(plan.size() == 5);
  CHECK(plan[0].fault == PlannedFault::kDropDrive);
  CHECK(plan[0].cycles == 3);
  CHECK(plan[1].fault == PlannedFault::kCorruptAlive);
  CHECK(plan[2].fault == PlannedFault::kPush);
  CHECK(plan[2].cycles == 40);
  CHECK(plan[2].value == 650.5);
  CHECK(plan[3].value == 0.0015);
  CHECK(plan[4].cycles == 1);
  using Catch::Contains;
  CHECK_THROWS_WITH(clm::sim::parse_planned_faults("drop-everything"), Contains("unknown step 'drop-everything'"));
  CHECK_THROWS_WITH(clm::sim::parse_planned_faults("corrupt-alive:2"), Contains("takes no count"));
  CHECK_THROWS_WITH(clm::sim::parse_planned_faults("push:10"), Contains("needs name:count:value"));
  CHECK_THROWS_WITH(clm::sim::parse_planned_faults("drop-drive:3:1"), Contains("takes no value"));
  CHECK_THROWS_WITH(clm::sim::parse_planned_faults("push:10:-5"), Contains("> 0 N"));
  CHECK_THROWS_WITH(clm::sim::parse_planned_faults("push:10:nan"), Contains("finite number"));
  CHECK_THROWS_WITH(clm::sim::parse_planned_faults("stall:3:0.5"), Contains("0 < S <= 0.1 s"));
  CHECK_THROWS_WITH(clm::sim::parse_planned_faults("drop-drive:0"), Contains("1 … 1000"));
  CHECK_THROWS_WITH(clm::sim::parse_planned_faults("drop-drive:1001"), Contains("1 … 1000"));
  CHECK_THROWS_WITH(clm::sim::parse_planned_faults("drop-drive,,bus-off"), Contains("no name"));
  CHECK_THROWS(clm::sim::parse_planned_faults(""));
}

TEST_CASE("a requested step fires at the next SYNC and acts on exactly its frames or cycles", "[sim][injection]") {
  Bench bench;
  bench.bus.set_plan(clm::sim::parse_planned_faults("drop-drive:2,bus-off:3,drop-force"));
  CHECK(bench.sync() == std::pair{1, 1});  // nothing requested: nothing happens
  CHECK(bench.bus.steps_fired() == 0);

  bench.bus.request_next_step();
  CHECK(bench.sync() == std::pair{0, 1});
  CHECK(bench.sync() == std::pair{0, 1});
  CHECK(bench.sync() == std::pair{1, 1});
  CHECK(bench.bus.steps_fired() == 1);

  bench.bus.request_next_step();
  CHECK(bench.bus.state() == clm::drivers::BusState::kActive);  // not before the SYNC
  for (int k = 0; k < 3; ++k) {
    bench.sync();
    CHECK(bench.bus.state() == clm::drivers::BusState::kBusOff);
  }
  bench.sync();
  CHECK(bench.bus.state() == clm::drivers::BusState::kActive);

  bench.bus.request_next_step();
  bench.bus.request_next_step();  // beyond the plan: ignored
  CHECK(bench.sync() == std::pair{1, 0});
  CHECK(bench.sync() == std::pair{1, 1});
  CHECK(bench.bus.steps_fired() == 3);
}

TEST_CASE("a push acts against the motion for its cycles while the drive is enabled, then ends", "[sim][injection]") {
  // Zero setpoints with the drive enabled: only the push, cogging and
  // friction act on the translator.
  Bench bench;
  bench.motor.reset(0.0, 0.2);
  bench.bus.set_plan(clm::sim::parse_planned_faults("push:50:300,push:50:300"));
  const std::vector<clm::DriveSetpoint> zero(static_cast<std::size_t>(bench.motor.coil_sets()));
  const auto enabled_sync = [&] {
    bench.motor.command(zero, true);
    bench.sync();
  };
  // The drive enables after its enable delay; the push is for an enabled drive.
  for (int k = 0; k < 100 && !bench.motor.status().enabled(); ++k) enabled_sync();
  REQUIRE(bench.motor.status().enabled());
  bench.bus.request_next_step();
  const double v0 = bench.motor.truth().velocity_m_per_s;
  for (int k = 0; k < 50; ++k) enabled_sync();
  const double v1 = bench.motor.truth().velocity_m_per_s;
  // 300 N against +y on the 15 kg translator for 50 ms: 1 m/s less.
  const double mass_kg = bench.motor.parameters().mechanics.translator_mass_kg;
  CHECK(v1 < v0 - 0.9 * 300.0 / mass_kg * 0.05);
  for (int k = 0; k < 20; ++k) enabled_sync();
  const double v2 = bench.motor.truth().velocity_m_per_s;
  // Afterwards no push: far less change than the push made.
  CHECK(std::abs(v2 - v1) < 0.2 * std::abs(v1 - v0));

  // With the drive disabled the fixture lets go at once.
  bench.motor.command(zero, false);
  bench.bus.request_next_step();
  bench.sync();
  const double v3 = bench.motor.truth().velocity_m_per_s;
  for (int k = 0; k < 20; ++k) bench.sync();
  CHECK(std::abs(bench.motor.truth().velocity_m_per_s - v3) < 0.2 * std::abs(v1 - v0));
  CHECK(bench.bus.steps_fired() == 2);
}

TEST_CASE("the motor's disturbance force accelerates the translator and reset removes it", "[sim]") {
  // No cogging, no friction: nothing else acts on the translator.
  const auto parameters = clm::sim::fixtures::ideal_motor(1);
  clm::sim::SimulatedMotor motor(parameters);
  motor.set_disturbance_force_N(30.0);
  for (int k = 0; k < 100; ++k) motor.step(0.001);
  // v = F/m t without friction, cogging or current.
  const double expected = 30.0 / parameters.mechanics.translator_mass_kg * 0.1;
  CHECK(motor.truth().velocity_m_per_s == Approx(expected).epsilon(1e-6));
  motor.reset(0.0);
  for (int k = 0; k < 100; ++k) motor.step(0.001);
  CHECK(motor.truth().velocity_m_per_s == 0.0);
  motor.set_disturbance_force_N(NAN);
  for (int k = 0; k < 10; ++k) motor.step(0.001);
  CHECK(motor.truth().velocity_m_per_s == 0.0);
}
