// The configuration keys of command authority and file loading: axis name,
// commands.*, telemetry.allow_network for a ttl above 0.
#include <catch2/catch.hpp>

#include <filesystem>

#include "config/yaml_reader.hpp"
#include "daemon/servod/servod_config.hpp"
#include "drivers/can/can_protocol.hpp"

using namespace clm;

namespace {

const std::string kSource = CLM_SOURCE_DIR;

servod::ServodConfig parse(const std::string& extra) {
  const std::string text = "motor_file: " + kSource + "/config/motor-sim.yaml\n" +
                           "control:\n  mass_kg: 15.0\n" + extra;
  return servod::parse_servod_config(yaml::Node::load_string(text, "test.yaml"), kSource + "/config");
}

}  // namespace

TEST_CASE("axis name, command age, lease and file directories have defaults and are read", "[config][commands]") {
  const auto defaults = parse("");
  CHECK(defaults.axis_name == "axis0");
  CHECK(defaults.commands.max_age_s == 2.0);
  CHECK(defaults.commands.control_lease_s == 30.0);
  CHECK(defaults.commands.deadman_timeout_s == 1.0);
  REQUIRE(defaults.commands.file_directories.size() == 1);
  CHECK(defaults.commands.file_directories[0] == std::filesystem::canonical(kSource + "/config").string());

  const auto set = parse("axis:\n  name: stage-x.1\ncommands:\n  max_age_s: 0.5\n  control_lease_s: 5\n"
                         "  deadman_timeout_s: 0.5\n  max_file_bytes: 4096\n  file_directories: [programs, /tmp]\n");
  CHECK(set.axis_name == "stage-x.1");
  CHECK(set.commands.max_age_s == 0.5);
  CHECK(set.commands.control_lease_s == 5.0);
  CHECK(set.commands.deadman_timeout_s == 0.5);
  CHECK(set.commands.max_file_bytes == 4096);
  REQUIRE(set.commands.file_directories.size() == 2);
  CHECK(set.commands.file_directories[0] == std::filesystem::canonical(kSource + "/config/programs").string());
  CHECK(set.commands.file_directories[1] == std::filesystem::canonical("/tmp").string());
}

TEST_CASE("bad axis names, directories and limits are refused naming line and key", "[config][commands]") {
  CHECK_THROWS_WITH(parse("axis:\n  name: \"x y\"\n"), Catch::Contains("test.yaml:5") && Catch::Contains("axis.name"));
  CHECK_THROWS_WITH(parse("axis:\n  name: \"\"\n"), Catch::Contains("axis.name"));
  CHECK_THROWS_WITH(parse("commands:\n  file_directories: [/nonexistent-clm-dir]\n"),
                    Catch::Contains("file_directories") && Catch::Contains("/nonexistent-clm-dir"));
  CHECK_THROWS_WITH(parse("commands:\n  file_directories: [motor-sim.yaml]\n"), Catch::Contains("not a directory"));
  CHECK_THROWS_WITH(parse("commands:\n  file_directories: []\n"), Catch::Contains("at least one"));
  CHECK_THROWS_WITH(parse("commands:\n  max_age_s: 0\n"), Catch::Contains("commands.max_age_s"));
  CHECK_THROWS_WITH(parse("commands:\n  owner: me\n"), Catch::Contains("owner"));
}

TEST_CASE("files the configuration names obey commands.file_directories, as files commands name do",
          "[config][commands][files]") {
  // The configuration's directory is the default directory: a file there is
  // accepted and canonical, one outside (the source tree's README) refused.
  const auto inside = parse("commutation:\n  calibration_file: motor-sim.yaml\n");
  CHECK(inside.commutation.calibration_file == std::filesystem::canonical(kSource + "/config/motor-sim.yaml").string());
  CHECK_THROWS_WITH(parse("commutation:\n  calibration_file: ../README.md\n"),
                    Catch::Contains("test.yaml:5") && Catch::Contains("commutation.calibration_file") &&
                        Catch::Contains("outside the directories"));
  const std::string feedforward_outside = "motor_file: " + kSource + "/config/motor-sim.yaml\n" +
                                          "control:\n  mass_kg: 15.0\n  feedforward_file: ../README.md\n";
  CHECK_THROWS_WITH(
      servod::parse_servod_config(yaml::Node::load_string(feedforward_outside, "test.yaml"), kSource + "/config"),
      Catch::Contains("control.feedforward_file") && Catch::Contains("outside the directories"));
  CHECK_THROWS_WITH(parse("commutation:\n  spline_model_file: motor-sim.yaml\ncommands:\n  file_directories: [programs]\n"),
                    Catch::Contains("commutation.spline_model_file") && Catch::Contains("outside the directories"));
}

TEST_CASE("commands.key_file is resolved beside the configuration", "[config][commands]") {
  CHECK(parse("commands:\n  key_file: command.key\n").commands.key_file == kSource + "/config/command.key");
  CHECK(parse("commands:\n  key_file: /etc/other.key\n").commands.key_file == "/etc/other.key");
}

TEST_CASE("a ttl above 0 needs telemetry.allow_network", "[config][commands]") {
  CHECK_THROWS_WITH(parse("telemetry:\n  lcm_url: \"udpm://239.255.76.67:7667?ttl=255\"\n"),
                    Catch::Contains("test.yaml:5") && Catch::Contains("ttl=255") && Catch::Contains("allow_network"));
  CHECK_NOTHROW(parse("telemetry:\n  lcm_url: \"udpm://239.255.76.67:7667?ttl=1\"\n  allow_network: true\n"));
  CHECK_NOTHROW(parse("telemetry:\n  lcm_url: \"udpm://239.255.76.67:7667?ttl=0\"\n"));
  CHECK_THROWS_WITH(parse("telemetry:\n  lcm_url: \"udpm://239.255.76.67:7667?ttl=999\"\n"), Catch::Contains("0..255"));
  CHECK(servod::lcm_url_ttl("udpm://239.255.76.67:7667") == 0);
  CHECK(servod::lcm_url_ttl("udpm://239.255.76.67:7667?recv_buf_size=4194304&ttl=3") == 3);
  CHECK(servod::lcm_url_ttl("file:///tmp/x.lcm") == -1);
}

TEST_CASE("can.force_sensor_node_id absent means no force sensor, and when present it must be a node 1..127 other than the "
          "drive's",
          "[config][force_sensor]") {
  CHECK_FALSE(can::has_force_sensor(parse("").servo.protocol));
  CHECK_FALSE(can::has_force_sensor(parse("can:\n  drive_node_id: 3\n").servo.protocol));
  const auto with = parse("can:\n  force_sensor_node_id: 5\n");
  CHECK(with.servo.protocol.force_sensor_node_id == 5);
  CHECK_THROWS_WITH(parse("can:\n  force_sensor_node_id: 0\n"),
                    Catch::Contains("test.yaml:") && Catch::Contains("force_sensor_node_id"));
  CHECK_THROWS_WITH(parse("can:\n  force_sensor_node_id: 1\n"), Catch::Contains("force_sensor_node_id"));
}
