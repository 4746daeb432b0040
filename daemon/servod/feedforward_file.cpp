#include "daemon/servod/feedforward_file.hpp"

namespace clm::servod {

std::string format_feedforward_file(const FeedforwardFile& file) {
  YAML::Emitter out;
  out << YAML::Comment("clm-servo feedforward, eq. (40); format in docs/data-formats.md");
  out << YAML::BeginMap;
  out << YAML::Key << "format" << YAML::Value << "clm-servo-feedforward";
  out << YAML::Key << "format_version" << YAML::Value << 1;
  out << YAML::Key << "mass_kg" << YAML::Value << yaml::format_double(file.parameters.mass_kg);
  out << YAML::Key << "viscous_N_s_per_m" << YAML::Value << yaml::format_double(file.parameters.viscous_N_s_per_m);
  out << YAML::Key << "coulomb_N" << YAML::Value << yaml::format_double(file.parameters.coulomb_N);
  out << YAML::Key << "provenance" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "data_sha256" << YAML::Value << YAML::DoubleQuoted << file.data_sha256;
  out << YAML::Key << "created_utc" << YAML::Value << YAML::DoubleQuoted << file.created_utc;
  out << YAML::Key << "generator" << YAML::Value << YAML::DoubleQuoted << file.generator;
  out << YAML::EndMap << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

FeedforwardFile parse_feedforward_file(const yaml::Node& root) {
  root.expect_keys({"format", "format_version", "mass_kg", "viscous_N_s_per_m", "coulomb_N", "provenance"});
  if (root["format"].as_string() != "clm-servo-feedforward") root["format"].fail("expected 'clm-servo-feedforward'");
  root["format_version"].as_integer_in(1, 1);
  FeedforwardFile file;
  file.parameters.mass_kg = root["mass_kg"].as_double();
  file.parameters.viscous_N_s_per_m = root["viscous_N_s_per_m"].as_double();
  file.parameters.coulomb_N = root["coulomb_N"].as_double();
  if (const auto provenance = root.optional("provenance")) {
    provenance->expect_keys({"data_sha256", "created_utc", "generator"});
    if (const auto v = provenance->optional("data_sha256")) file.data_sha256 = v->as_string();
    if (const auto v = provenance->optional("created_utc")) file.created_utc = v->as_string();
    if (const auto v = provenance->optional("generator")) file.generator = v->as_string();
  }
  return file;
}

FeedforwardFile load_feedforward_file(const std::string& path) {
  return parse_feedforward_file(yaml::Node::load_file(path));
}

}  // namespace clm::servod
