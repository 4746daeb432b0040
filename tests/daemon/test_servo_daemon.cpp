// The daemon core on the in-process simulated motor, virtual clock.
#include <catch2/catch.hpp>
#include <cmath>

#include "daemon/control/metrics.hpp"
#include "daemon/servod/servo_daemon.hpp"
#include "drivers/sim/in_process_bus.hpp"
#include "drivers/sim/motor.hpp"
#include "tests/daemon/daemon_support.hpp"

using namespace clm;
using Kind = servo::CommandKind;

TEST_CASE("the daemon runs the Fig. 8 program with the drive's own commutation and tracks it", "[daemon][tracking]") {
  servod::WiredAxis axis(test::virtual_config());
  servod::ServoDaemon& daemon = axis.daemon;
  daemon.run_cycles(10);
  test::command(daemon, Kind::kEnable);
  REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
  servo::Command run;
  run.kind = Kind::kRunProgram;
  run.program.assign(test::absolute_encoder_file("programs/fig8.yaml"));
  const auto reply = daemon.submit(run);
  REQUIRE(reply.accepted());
  double max_error = 0.0, sum_sq = 0.0;
  std::int64_t n = 0;
  while (true) {
    daemon.run_cycles(1);
    const auto& record = daemon.cycle().record();
    REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
    if (!record.program_running && n > 10) break;
    // Independent of the daemon's own record: the simulator's true position.
    const double error = record.r_m - axis.simulated_motor()->truth().position_m;
    max_error = std::max(max_error, std::abs(error));
    sum_sq += error * error;
    ++n;
    REQUIRE(n < 40000);
  }
  INFO("cycles " << n << " max error " << max_error << " mse " << sum_sq / n);
  CHECK(n > 25000);
  CHECK(max_error < 1e-3);
  CHECK(std::abs(axis.simulated_motor()->truth().position_m - (-0.1)) < 1e-4);
}
