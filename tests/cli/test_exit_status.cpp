// The exit status and error line convention of every program
// (config/exit_status.hpp, docs/design-decisions.md "Exit status and error
// messages"), on the real binaries: 2 and one stderr line with the program's
// prefix for bad usage and bad input, 1 and one line for a failure at run
// time, the nearest subcommand or option for a mistyped one, readable ranges,
// and a configuration error of a derived value naming file, line and key.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli/cli_support.hpp"
#include "support/temporary_directory.hpp"

using namespace clm::cli_test;
namespace fs = std::filesystem;

namespace {

std::string joined(const std::vector<std::string>& args) {
  std::string text;
  for (const auto& a : args) text += " " + a;
  return text;
}

/// Checks exit status `status`, nothing on stdout and exactly `line` on stderr.
void check_one_line(const ProcessResult& result, int status, const std::string& line) {
  INFO("stdout: " << result.out << "\nstderr: " << result.err);
  CHECK(result.exit_code == status);
  CHECK(result.out.empty());
  const auto lines = result.err_lines();
  REQUIRE(lines.size() == 1);
  CHECK(lines[0] == line);
}

/// The 1-based line of `text` that starts with `prefix`.
std::size_t line_starting(const std::string& text, const std::string& prefix) {
  const std::size_t at = text.find("\n" + prefix);
  REQUIRE(at != std::string::npos);
  return 2 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
}

/// An operators' key of this test process (config/command_key.hpp).
const std::string& test_key_file() {
  static const clm::test::TemporaryDirectory directory("clm_cli_key");
  static const std::string path = [] {
    const std::string file = directory.file("command.key");
    std::ofstream(file, std::ios::binary) << std::string(32, 'k');
    ::chmod(file.c_str(), 0600);
    return file;
  }();
  return path;
}

/// An LCM URL of this process's own and an axis no daemon drives: `clm ctl`
/// waits for it in vain.
std::vector<std::string> ctl_with_no_daemon(const std::vector<std::string>& subcommand) {
  std::vector<std::string> args = {"ctl",
                                   "--key-file",
                                   test_key_file(),
                                   "--lcm-url",
                                   "udpm://239.255.76.67:" + std::to_string(10240 + ::getpid() % 40) + "?ttl=0",
                                   "--axis",
                                   "no-such-axis-" + std::to_string(::getpid()),
                                   "--timeout-s",
                                   "0.2"};
  args.insert(args.end(), subcommand.begin(), subcommand.end());
  return args;
}

}  // namespace

TEST_CASE("clm: a mistyped subcommand exits 2 with one line naming the nearest one", "[cli][exit_status]") {
  check_one_line(run_clm({"comission", "--out", "x"}), 2,
                 "clm: error: unknown subcommand 'comission'; did you mean 'commission'?");
  check_one_line(run_clm({"calibrat"}), 2, "clm: error: unknown subcommand 'calibrat'; did you mean 'calibrate'?");
  check_one_line(run_clm({"ctl", "stauts"}), 2, "clm ctl: error: unknown subcommand 'stauts'; did you mean 'status'?");
  // Nothing near: the list of subcommands.
  const ProcessResult far = run_clm({"xyzzy"});
  CHECK(far.exit_code == 2);
  REQUIRE(far.err_lines().size() == 1);
  CHECK(far.err_lines()[0].rfind("clm: error: unknown subcommand 'xyzzy' (one of: calibrate, identify, ", 0) == 0);
  // No subcommand at all.
  const ProcessResult none = run_clm({});
  CHECK(none.exit_code == 2);
  REQUIRE(none.err_lines().size() == 1);
  CHECK(none.err_lines()[0].rfind("clm: error: a subcommand is required: calibrate, identify, ", 0) == 0);
}

TEST_CASE("clm subcommands: a mistyped option exits 2 with one line naming the nearest option", "[cli][exit_status]") {
  const std::string motor = source_path("config/motor-sim.yaml");
  check_one_line(run_clm({"calibrate", "--moter", motor, "--data", motor, "--output", "c.yaml"}), 2,
                 "clm calibrate: error: unknown option '--moter'; did you mean '--motor'?");
  check_one_line(run_clm({"commission", "--confg", "servod.yaml", "--out", "x"}), 2,
                 "clm commission: error: unknown option '--confg'; did you mean '--config'?");
  // ctl's own options are taken after its subcommand too (fallthrough).
  check_one_line(run_clm({"ctl", "status", "--timeout", "1"}), 2,
                 "clm ctl: error: unknown option '--timeout'; did you mean '--timeout-s'?");
  check_one_line(run_clm({"log2csv", "--log", motor, "--output", "o.csv", "--format", "full", "--max-row", "5"}), 2,
                 "clm log2csv: error: unknown option '--max-row'; did you mean '--max-rows'?");
}

TEST_CASE("clm subcommands: a value out of range exits 2 with the value and readable bounds", "[cli][exit_status]") {
  const std::string motor = source_path("config/motor-sim.yaml");
  check_one_line(run_clm({"sim", "--can", "vcan0", "--motor", motor, "--duration-s", "-1"}), 2,
                 "clm sim: error: --duration-s: -1 is not > 0");
  check_one_line(run_clm({"sim", "--can", "vcan0", "--motor", motor, "--drive-node-id", "200"}), 2,
                 "clm sim: error: --drive-node-id: 200 is not in [1, 127]");
  check_one_line(run_clm({"ctl", "--timeout-s", "0", "status"}), 2, "clm ctl: error: --timeout-s: 0 is not > 0");
  check_one_line(run_clm({"ctl", "jog", "--velocity-m-per-s", "0.1", "--repeat-s", "2"}), 2,
                 "clm ctl: error: --repeat-s: 2 is not in [0.01, 1]");
  check_one_line(run_clm({"ctl", "--client-id", "0", "status"}), 2, "clm ctl: error: --client-id: 0 is not >= 1");
  check_one_line(run_clm({"identify", "--motor", motor, "--data", motor, "--output", "m.yaml", "--threads", "x"}), 2,
                 "clm identify: error: --threads: 'x' is not a number");
}

TEST_CASE("clm ctl without a daemon: exit 1 and one stderr line, nothing on stdout", "[cli][exit_status]") {
  for (const std::vector<std::string>& subcommand :
       {std::vector<std::string>{"status"}, std::vector<std::string>{"enable"}, std::vector<std::string>{"get"},
        std::vector<std::string>{"set", "motion.velocity_m_per_s", "0.2"}}) {
    const auto args = ctl_with_no_daemon(subcommand);
    INFO("clm" << joined(args));
    const ProcessResult result = run_clm(args);
    INFO("stdout: " << result.out << "\nstderr: " << result.err);
    CHECK(result.exit_code == 1);
    CHECK(result.out.empty());
    const auto lines = result.err_lines();
    REQUIRE(lines.size() == 1);
    CHECK(lines[0].rfind("clm ctl: error: no CLM_SERVO_", 0) == 0);
    CHECK(lines[0].find("no-such-axis-") != std::string::npos);
  }
}

TEST_CASE("clm and clm-servod: --help exits 0 with the usage on stdout and nothing on stderr", "[cli][exit_status]") {
  for (const ProcessResult& result : {run_clm({"--help"}), run_clm({"ctl", "--help"}), run_servod({"--help"})}) {
    CHECK(result.exit_code == 0);
    CHECK(result.out.find("Usage:") != std::string::npos);
    CHECK(result.err.empty());
  }
}

TEST_CASE("clm-servod: bad usage exits 2 with one 'clm-servod: error:' line", "[cli][exit_status][servod]") {
  check_one_line(run_servod({}), 2, "clm-servod: error: --config is required");
  check_one_line(run_servod({"--confg", "servod.yaml"}), 2,
                 "clm-servod: error: unknown option '--confg'; did you mean '--config'?");
  check_one_line(run_servod({"--config", source_path("config/servod.yaml"), "--duration-s", "-1"}), 2,
                 "clm-servod: error: --duration-s: -1 is not > 0");
  check_one_line(run_servod({"--config", source_path("config/servod.yaml"), "extra"}), 2,
                 "clm-servod: error: The following argument was not expected: extra");
  TemporaryDirectory dir("clm-servod-usage");
  const std::string missing = dir.file("missing.yaml");
  const ProcessResult result = run_servod({"--config", missing});
  CHECK(result.exit_code == 2);
  REQUIRE(result.err_lines().size() == 1);
  CHECK(result.err_lines()[0].rfind("clm-servod: error: " + missing + ": ", 0) == 0);
}

TEST_CASE("clm-servod: a mass_kg whose PID gains overflow is refused naming file, line, key and value",
          "[cli][exit_status][servod]") {
  TemporaryDirectory dir("clm-servod-mass");
  std::string text = read_file(source_path("config/servod.yaml"));
  const std::string relative = "motor_file: motor-sim.yaml";
  REQUIRE(text.find(relative) != std::string::npos);
  text.replace(text.find(relative), relative.size(), "motor_file: " + source_path("config/motor-sim.yaml"));
  // The line of control.mass_kg, whatever its value.
  const auto mass_at = text.find("\n  mass_kg: ");
  REQUIRE(mass_at != std::string::npos);
  const auto mass_end = text.find('\n', mass_at + 1);
  text.replace(mass_at + 1, mass_end - mass_at - 1, "  mass_kg: 1e308");
  const std::string config = dir.file("servod.yaml");
  write_file(config, text);
  const std::size_t line = line_starting(text, "  mass_kg: 1e308");
  // config/servod.yaml's control.bandwidth_hz: 40.
  check_one_line(run_servod({"--config", config, "--duration-s", "1"}), 2,
                 "clm-servod: error: " + config + ":" + std::to_string(line) +
                     ": control.mass_kg: value 1e308 kg gives non-finite PID gains at control.bandwidth_hz 40 Hz "
                     "(k_p grows with mass_kg * bandwidth_hz^2, k_i with mass_kg * bandwidth_hz^3)");
  // clm reads the same configuration the same way.
  const std::string out = dir.file("out");
  check_one_line(run_clm({"commission", "--config", config, "--out", out}), 2,
                 "clm commission: error: " + config + ":" + std::to_string(line) +
                     ": control.mass_kg: value 1e308 kg gives non-finite PID gains at control.bandwidth_hz 40 Hz "
                     "(k_p grows with mass_kg * bandwidth_hz^2, k_i with mass_kg * bandwidth_hz^3)");
  CHECK_FALSE(fs::exists(out));
}

TEST_CASE("clm ctl with a missing or unsafe key file: exit 2 and one line naming the file", "[cli][exit_status]") {
  const clm::test::TemporaryDirectory directory("clm_cli_bad_key");
  const std::string missing = directory.file("absent.key");
  const std::string open_key = directory.file("open.key");
  std::ofstream(open_key, std::ios::binary) << std::string(32, 'k');
  ::chmod(open_key.c_str(), 0644);
  for (const auto& [file, words] : {std::pair{missing, std::string("cannot open")}, std::pair{open_key, std::string("mode 0644")}}) {
    const ProcessResult result = run_clm({"ctl", "--key-file", file, "--timeout-s", "0.2", "status"});
    INFO("stdout: " << result.out << "\nstderr: " << result.err);
    CHECK(result.exit_code == 2);
    CHECK(result.out.empty());
    const auto lines = result.err_lines();
    REQUIRE(lines.size() == 1);
    CHECK(lines[0].rfind("clm ctl: error: " + file, 0) == 0);
    CHECK(lines[0].find(words) != std::string::npos);
  }
}

TEST_CASE("clm commission refuses a payload it cannot use: exit 2 and the one rule's line", "[cli][exit_status]") {
  // commission::payload_refusal, the rule the library applies too: a
  // payload needs --no-force-sensor and no other source of the force scale.
  const clm::test::TemporaryDirectory directory("clm_cli_payload");
  const std::string config = source_path("config/servod.yaml"), out = directory.file("out");
  const std::string rule = ": a payload gives the mass of the commissioning from positions; it needs "
                           "--no-force-sensor, a positive finite mass, and neither --mass-kg nor a friction";
  check_one_line(run_clm({"commission", "--config", config, "--out", out, "--payload-kg", "5"}), 2,
                 "clm commission: error: --payload-kg 5" + rule);
  check_one_line(run_clm({"commission", "--config", config, "--out", out, "--no-force-sensor", "--mass-kg", "15",
                          "--payload-kg", "5"}),
                 2, "clm commission: error: --payload-kg 5" + rule);
  CHECK_FALSE(fs::exists(out));
}
