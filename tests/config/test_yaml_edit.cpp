// Edits of a configuration as text: the edited key reads back with the new
// value through the strict reader, and every other line stays byte for byte.
#include <catch2/catch.hpp>

#include "config/yaml_edit.hpp"
#include "config/yaml_reader.hpp"

using namespace clm;

namespace {

const std::string kText =
    "# a servo configuration\n"
    "motor_file: motor.yaml   # beside this file\n"
    "\n"
    "control:\n"
    "  mass_kg: 15.0                  # translator\n"
    "  bandwidth_hz: 40.0\n"
    "  feedforward: {mass_kg: 0.0, viscous_N_s_per_m: 0.0, coulomb_N: 0.0}   # eq. (40)\n"
    "  # a comment inside the section\n"
    "\n"
    "motion:\n"
    "  velocity_m_per_s: 0.5          # move-to may not ask for more\n";

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t end = text.find('\n', at);
    out.push_back(text.substr(at, end - at));
    at = end == std::string::npos ? text.size() : end + 1;
  }
  return out;
}

}  // namespace

TEST_CASE("a value is replaced on its line, its comment kept, every other line unchanged", "[yaml_edit]") {
  const std::string edited = yaml::set_value(kText, "control.bandwidth_hz", "25.5");
  const auto before = lines_of(kText), after = lines_of(edited);
  REQUIRE(before.size() == after.size());
  for (std::size_t i = 0; i < before.size(); ++i) {
    if (i == 5) continue;
    CHECK(after[i] == before[i]);
  }
  CHECK(after[5] == "  bandwidth_hz: 25.5");
  const auto root = yaml::Node::load_string(edited, "edited.yaml");
  CHECK(root["control"]["bandwidth_hz"].as_double() == 25.5);

  const std::string commented = yaml::set_value(kText, "motion.velocity_m_per_s", "0.25");
  CHECK(lines_of(commented).back() == "  velocity_m_per_s: 0.25         # move-to may not ask for more");
  CHECK(yaml::Node::load_string(commented, "e.yaml")["motion"]["velocity_m_per_s"].as_double() == 0.25);

  const std::string flow = yaml::set_value(kText, "control.feedforward", "{mass_kg: 15.2, viscous_N_s_per_m: 3.5, coulomb_N: 8}");
  const auto ff = yaml::Node::load_string(flow, "e.yaml")["control"]["feedforward"];
  CHECK(ff["mass_kg"].as_double() == 15.2);
  CHECK(ff["coulomb_N"].as_double() == 8.0);
  CHECK(lines_of(flow)[6].find("# eq. (40)") != std::string::npos);
}

TEST_CASE("a missing key is added at the end of its section, a missing section at the end", "[yaml_edit]") {
  const std::string added = yaml::set_value(kText, "control.feedforward_file", yaml::quoted("/var/lib/clm-servo/ff \"1\".yaml"));
  const auto root = yaml::Node::load_string(added, "e.yaml");
  CHECK(root["control"]["feedforward_file"].as_string() == "/var/lib/clm-servo/ff \"1\".yaml");
  CHECK(lines_of(added)[7] == "  feedforward_file: \"/var/lib/clm-servo/ff \\\"1\\\".yaml\"");
  CHECK(root["control"]["mass_kg"].as_double() == 15.0);

  const std::string section = yaml::set_value(kText, "commutation.mode", "pgnn");
  CHECK(yaml::Node::load_string(section, "e.yaml")["commutation"]["mode"].as_string() == "pgnn");
  CHECK(section.compare(0, kText.size(), kText) == 0);  // appended, nothing else changed

  const std::string no_newline = yaml::set_value("control:\n  mass_kg: 1", "commutation.mode", "pgnn");
  CHECK(no_newline == "control:\n  mass_kg: 1\ncommutation:\n  mode: pgnn\n");
}

TEST_CASE("a key is removed with its line alone", "[yaml_edit]") {
  const std::string removed = yaml::remove_key(kText, "control.feedforward");
  CHECK(lines_of(removed).size() == lines_of(kText).size() - 1);
  CHECK_FALSE(yaml::Node::load_string(removed, "e.yaml")["control"].has("feedforward"));
  CHECK(yaml::remove_key(kText, "control.nothing") == kText);
  CHECK(yaml::remove_key(kText, "nothing.here") == kText);
}

TEST_CASE("keys that are not section.key, flow-style sections and repeated keys are refused", "[yaml_edit]") {
  CHECK_THROWS_WITH(yaml::set_value(kText, "control", "1"), Catch::Contains("expected section.key"));
  CHECK_THROWS_WITH(yaml::set_value(kText, "a.b.c", "1"), Catch::Contains("expected section.key"));
  CHECK_THROWS_WITH(yaml::set_value("motion: {velocity_m_per_s: 1}\n", "motion.velocity_m_per_s", "2"),
                    Catch::Contains("not in block style"));
  CHECK_THROWS_WITH(yaml::set_value("motion:\n  a: 1\n  a: 2\n", "motion.a", "3"), Catch::Contains("twice"));
  CHECK_THROWS_WITH(yaml::set_value("motion:\n  a:\n    b: 1\n", "motion.a", "3"), Catch::Contains("further lines"));
}
