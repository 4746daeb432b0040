// The cycle does not allocate (style rule 3): 10^5 cycles of the daemon's
// loop on the virtual clock, the axis enabled and running a program, in every
// commutation mode, with the allocations of this thread counted. Everything a
// cycle does is in the count: commands drained, reference, PID, commutation,
// codec, the in-process bus and the simulated drive and sensor nodes. Both
// operator new and the C heap functions (Eigen's) are counted.
#include <catch2/catch.hpp>

#include <Eigen/Core>
#include <memory>

#include "daemon/servod/program_file.hpp"
#include "daemon/servod/servo_daemon.hpp"
#include "support/allocation_counter.hpp"
#include "tests/daemon/daemon_support.hpp"
#include "tests/daemon/malloc_counter.hpp"

using namespace clm;
using Kind = servo::CommandKind;
using servo::CommutationMode;

namespace {

/// 10^5 cycles of `mode` with a program running on the axis of `servod_file`,
/// counted; with `current_loop`, the cycle also compensates a drive's current
/// loop (the simulated drive's own stays as the motor file has it), and an
/// experiment takes the back-EMF's gains from the law `service`.
void check_cycles_allocate_nothing(CommutationMode mode, const std::string& servod_file,
                                   const std::string& motor_file, const CurrentLoopModel& current_loop = {},
                                   CommutationMode service = CommutationMode::kOriginal) {
  constexpr std::int64_t kCycles = 100'000;
  test::TemporaryDirectory dir("clm-daemon-allocations");
  const auto files = test::write_truth_laws(dir, test::source_path(motor_file));
  INFO("mode " << servo::name(mode) << " (in service " << servo::name(service) << "), " << servod_file);
  servod::ServodConfig config = test::config_with_laws(files, service, servod_file);
  config.motor.current_loop = config.servo.current_loop = current_loop;
  servod::WiredAxis axis(config);
  servod::ServoDaemon& daemon = axis.daemon;
  daemon.run_cycles(10);
  if (mode == CommutationMode::kExperiment) {
    // Algorithms 1 and 2: the whole demand through coil set 2 at Δ = π/4.
    test::submit_experiment(daemon, 2, kPi / 4);
  } else {
    servo::Command set;
    set.kind = Kind::kSetCommutation;
    set.commutation = mode;
    REQUIRE(daemon.submit(set).accepted());
  }
  test::command(daemon, Kind::kEnable, 10);
  REQUIRE(daemon.cycle().status().mode == mode);
  REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);

  // Fig. 8 four times over (≈ 124 s): a program runs through all 10^5 cycles.
  servod::ProgramFile fig8 = servod::load_program_file(test::source_path("config/programs/fig8.yaml"));
  servod::ProgramFile program = fig8;
  for (int k = 0; k < 3; ++k) program.steps.insert(program.steps.end(), fig8.steps.begin(), fig8.steps.end());
  REQUIRE(daemon.submit_program(program).accepted());
  daemon.run_cycles(1);
  REQUIRE(daemon.cycle().record().program_running);
  // A command waiting in the queue: draining it is part of the counted cycles.
  servo::Command feedforward;
  feedforward.kind = Kind::kLoadFeedforward;  // no path: the parameters as given
  feedforward.feedforward = daemon.config().servo.feedforward;
  REQUIRE(daemon.submit(feedforward).accepted());

  const auto before = daemon.cycle().status().counters;
  std::size_t allocations = 0;
  const std::size_t malloc_before = test::malloc_calls();
  {
    test::AllocationScope scope;
    daemon.run_cycles(kCycles);
    allocations = scope.allocations();
  }
  const std::size_t malloc_calls = test::malloc_calls() - malloc_before;
  const auto& after = daemon.cycle().status().counters;
  CHECK(allocations == 0);
  CHECK(malloc_calls == 0);
  CHECK(after.cycles - before.cycles == kCycles);
  // It really drove the axis, with feedback in every cycle, all the way.
  REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
  CHECK(daemon.cycle().record().program_running);
  CHECK(after.frames_missing == before.frames_missing);
  CHECK(test::sent_setpoints(axis).command.enable);
  // The law request, enable, the program (once the cycle took it) and the
  // feedforward: each answered, in that order.
  const auto replies = daemon.take_replies();
  REQUIRE(replies.size() == 4);
  for (const auto& reply : replies) CHECK(reply.accepted());
  CHECK(replies[2].text() == "program posted");
}

}  // namespace

TEST_CASE("10^5 cycles with a program running allocate nothing, in every commutation mode", "[daemon][allocation]") {
  const auto mode = GENERATE(CommutationMode::kOriginal, CommutationMode::kClassical, CommutationMode::kPgnn,
                             CommutationMode::kSpline, CommutationMode::kOracle, CommutationMode::kExperiment);
  check_cycles_allocate_nothing(mode, "config/servod.yaml", "config/motor-sim.yaml");
}

TEST_CASE("10^5 cycles allocate nothing while compensating a drive's current loop", "[daemon][allocation]") {
  const auto mode = GENERATE(CommutationMode::kClassical, CommutationMode::kPgnn, CommutationMode::kExperiment);
  check_cycles_allocate_nothing(mode, "config/servod.yaml", "config/motor-sim.yaml", {1500.0, 2.0, 1e-3});
}

TEST_CASE("10^5 cycles of an experiment allocate nothing with a model law's back-EMF gains", "[daemon][allocation]") {
  check_cycles_allocate_nothing(CommutationMode::kExperiment, "config/servod.yaml", "config/motor-sim.yaml",
                                {1500.0, 2.0, 1e-3}, CommutationMode::kPgnn);
}

TEST_CASE("10^5 cycles allocate nothing with a phase-current drive either", "[daemon][allocation][phase_current]") {
  const auto mode = GENERATE(CommutationMode::kOriginal, CommutationMode::kPgnn, CommutationMode::kExperiment);
  check_cycles_allocate_nothing(mode, "config/servod-phase-current.yaml", "config/motor-sim-phase-current.yaml");
  // The cycle really drove a phase-current drive.
  CHECK(test::virtual_config("config/servod-phase-current.yaml").servo.protocol.drive_profile ==
        DriveProfile::kPhaseCurrent);
}

TEST_CASE("stops, quick stops, a jog, the approach guard and fault reactions allocate nothing in the cycle",
          "[daemon][allocation]") {
  // Moves are posted between the counted stretches (planning them allocates,
  // on the command thread); everything the cycle does with them is counted:
  // adopting the move, planning and following a stop or quick stop from the
  // command queue, a quick stop as the reaction to a fault, and the approach
  // guard's prediction in every cycle of a move.
  servod::WiredAxis axis(test::virtual_config());
  servod::ServoDaemon& daemon = axis.daemon;
  const auto& s = daemon.config().servo;
  daemon.run_cycles(10);
  test::command(daemon, Kind::kEnable, 10);
  REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
  std::size_t allocations = 0;
  std::size_t malloc_calls = 0;
  const auto counted = [&](std::int64_t cycles) {
    const std::size_t malloc_before = test::malloc_calls();
    test::AllocationScope scope;
    daemon.run_cycles(cycles);
    allocations += scope.allocations();
    malloc_calls += test::malloc_calls() - malloc_before;
  };
  const auto before = daemon.cycle().status().counters;
  for (int round = 0; round < 20; ++round) {
    servo::Command move;
    move.kind = Kind::kMoveTo;
    move.target_m = round % 2 == 0 ? 0.1 : -0.1;
    move.limits = s.motion_limits;
    REQUIRE(daemon.submit(move).accepted());
    counted(100 + 7 * round);
    servo::Command stop;
    stop.kind = round % 3 == 0 ? Kind::kStop : Kind::kQuickStop;
    REQUIRE(daemon.submit(stop).accepted());
    counted(400);
    REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
    REQUIRE(daemon.cycle().mailbox().at_rest());
    (void)daemon.take_replies();
  }
  // A jog: renewed three times (renew_jog itself is lock-free and runs on
  // the command thread), then stopped by its timeout in the cycle.
  servo::Command jog;
  jog.kind = Kind::kJog;
  jog.jog_velocity_m_per_s = daemon.cycle().mailbox().hold_position_m() > 0.0 ? -0.1 : 0.1;
  jog.limits = {0.1, 1.0, 1000.0};
  (void)daemon.take_replies();
  REQUIRE(daemon.submit(jog).answered_later());
  counted(1);
  const auto started = daemon.take_replies();
  REQUIRE(started.size() == 1);
  REQUIRE(started[0].text() == "jog started");
  for (int k = 0; k < 3; ++k) {
    counted(100);
    REQUIRE(daemon.submit(jog).text() == "jogging");
  }
  counted(600);
  REQUIRE(daemon.cycle().mailbox().at_rest());
  CHECK(daemon.cycle().status().counters.jog_timeouts == 1);
  // A fault reaction: overruns reported while moving.
  servo::Command move;
  move.kind = Kind::kMoveTo;
  move.target_m = daemon.cycle().mailbox().hold_position_m() > 0.0 ? -0.1 : 0.1;
  move.limits = s.motion_limits;
  REQUIRE(daemon.submit(move).accepted());
  counted(100);
  {
    test::AllocationScope scope;
    for (int k = 0; k < s.overrun_limit; ++k) daemon.run_cycle_after(0.0, true);
    allocations += scope.allocations();
  }
  REQUIRE(daemon.cycle().status().fault_reaction_running);
  counted(500);
  CHECK_FALSE(daemon.cycle().status().fault_reaction_running);
  CHECK(allocations == 0);
  CHECK(malloc_calls == 0);
  const auto& after = daemon.cycle().status().counters;
  CHECK(after.stops - before.stops == 7 + 1);  // and the jog's
  CHECK(after.quick_stops - before.quick_stops == 13 + 1);
}

TEST_CASE("the heap counters see operator new and Eigen's malloc", "[daemon][allocation]") {
  volatile int size = 64;  // a size the compiler cannot see
  const std::size_t malloc_before = test::malloc_calls();
  double sum = 0.0;
  {
    test::AllocationScope scope;
    auto numbers = std::make_unique<double[]>(static_cast<std::size_t>(size));
    numbers[0] = 1.0;
    sum += numbers[0];
    CHECK(scope.allocations() == 1);
  }
  {
    Eigen::MatrixXd matrix = Eigen::MatrixXd::Ones(size, size);
    sum += matrix.sum();
  }
  CHECK(sum == 1.0 + 64.0 * 64.0);
  CHECK(test::malloc_calls() - malloc_before >= 2);
}
