#include "tools/commission/progress.hpp"

#include <lcm/lcm-cpp.hpp>

#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "config/atomic_file.hpp"
#include "config/sha256.hpp"
#include "config/yaml_edit.hpp"
#include "config/yaml_reader.hpp"
#include "daemon/telemetry/lcm_log_writer.hpp"
#include "tools/lcmlog/servo_log.hpp"

namespace clm::commission {
namespace {


}  // namespace

RunIdentity run_identity(const clm_lcm::servo_status_t& status, const std::string& experiment_program_path) {
  return {status.configuration_file, status.configuration_sha256, status.motor_file, status.motor_sha256,
          sha256_file(experiment_program_path)};
}

void write_progress(const std::string& dir, const CommissionProgress& progress) {
  const RunIdentity& id = progress.identity;
  std::ostringstream out;
  out << "# clm commission --live: the experiments completed, for --resume (docs/commissioning.md)\n"
      << "format: clm-commission-progress\nformat_version: 1\n"
      << "configuration_file: " << yaml::quoted(id.configuration_file) << "\n"
      << "configuration_sha256: " << yaml::quoted(id.configuration_sha256) << "\n"
      << "motor_file: " << yaml::quoted(id.motor_file) << "\n"
      << "motor_sha256: " << yaml::quoted(id.motor_sha256) << "\n"
      << "experiment_program_sha256: " << yaml::quoted(id.experiment_program_sha256) << "\n"
      << "experiments:" << (progress.experiments.empty() ? " []\n" : "\n");
  for (const auto& e : progress.experiments) {
    out << "  - {coil_set: " << e.coil_set << ", delta_rad: " << yaml::format_double(e.delta_rad)
        << ", log: " << yaml::quoted(e.log) << ", sha256: " << yaml::quoted(e.sha256) << "}\n";
  }
  write_file_atomically(dir + "/" + kProgressFile, out.str());
}

CommissionProgress read_progress(const std::string& dir) {
  const std::string path = dir + "/" + kProgressFile;
  if (!std::filesystem::is_regular_file(path)) {
    throw std::runtime_error(path + ": no such file: the directory holds no live commissioning to resume");
  }
  const yaml::Node root = yaml::Node::load_file(path);
  root.expect_keys({"format", "format_version", "configuration_file", "configuration_sha256", "motor_file",
                    "motor_sha256", "experiment_program_sha256", "experiments"});
  if (root["format"].as_string() != "clm-commission-progress") root["format"].fail("expected clm-commission-progress");
  (void)root["format_version"].as_integer_in(1, 1);
  CommissionProgress progress;
  RunIdentity& id = progress.identity;
  id.configuration_file = root["configuration_file"].as_string();
  id.configuration_sha256 = root["configuration_sha256"].as_string();
  id.motor_file = root["motor_file"].as_string();
  id.motor_sha256 = root["motor_sha256"].as_string();
  id.experiment_program_sha256 = root["experiment_program_sha256"].as_string();
  const yaml::Node list = root["experiments"];
  if (!list.is_sequence()) list.fail("expected a list");
  for (std::size_t k = 0; k < list.size(); ++k) {
    const yaml::Node entry = list.at(k);
    entry.expect_keys({"coil_set", "delta_rad", "log", "sha256"});
    CompletedExperiment e;
    e.coil_set = static_cast<int>(entry["coil_set"].as_integer_in(1, 8));
    e.delta_rad = entry["delta_rad"].as_double();
    e.log = entry["log"].as_string();
    if (e.log.empty() || e.log.front() == '/' || e.log.find("..") != std::string::npos) {
      entry["log"].fail("expected a path inside the output directory");
    }
    e.sha256 = entry["sha256"].as_string();
    progress.experiments.push_back(e);
  }
  return progress;
}

std::string check_resume(const std::string& dir, const RunIdentity& identity) {
  CommissionProgress progress;
  try {
    progress = read_progress(dir);
  } catch (const std::exception& e) {
    return std::string("--resume: ") + e.what() + ". Fix: give the --out of an interrupted clm commission --live";
  }
  const RunIdentity& was = progress.identity;
  const std::string fix = ". Fix: commission anew into another --out (the completed experiments were made for "
                          "another axis set-up)";
  if (was.configuration_sha256 != identity.configuration_sha256) {
    return "--resume " + dir + ": the experiments ran with the daemon's configuration " + was.configuration_file +
           " (SHA-256 " + was.configuration_sha256.substr(0, 12) + "…), the daemon now runs " +
           identity.configuration_file + " (SHA-256 " + identity.configuration_sha256.substr(0, 12) + "…)" + fix;
  }
  if (was.motor_sha256 != identity.motor_sha256) {
    return "--resume " + dir + ": the experiments ran with the motor " + was.motor_file + " (SHA-256 " +
           was.motor_sha256.substr(0, 12) + "…), the daemon now drives " + identity.motor_file + " (SHA-256 " +
           identity.motor_sha256.substr(0, 12) + "…)" + fix;
  }
  if (was.experiment_program_sha256 != identity.experiment_program_sha256) {
    return "--resume " + dir + ": the experiments ran another experiment program (SHA-256 " +
           was.experiment_program_sha256.substr(0, 12) + "…, now " +
           identity.experiment_program_sha256.substr(0, 12) + "…). Fix: give the same --experiment-program, or "
           "commission anew into another --out";
  }
  for (const auto& e : progress.experiments) {
    const std::string path = dir + "/" + e.log;
    std::string actual;
    try {
      actual = sha256_file(path);
    } catch (const std::exception& error) {
      return "--resume " + dir + ": the completed experiment's log " + e.log + " cannot be read (" + error.what() +
             "). Fix: commission anew into another --out";
    }
    if (actual != e.sha256) {
      return "--resume " + dir + ": the completed experiment's log " + e.log + " has SHA-256 " + actual.substr(0, 12) +
             "…, " + kProgressFile + " recorded " + e.sha256.substr(0, 12) +
             "… (changed since). Fix: commission anew into another --out";
    }
  }
  return "";
}

Recording read_experiment_recording(const std::string& log_path, const std::string& name) {
  Recording recording;
  recording.name = name;
  for (const servo::CycleRecord& s : lcmlog::read_servo_states(log_path)) {
    if (!s.program_running || s.state != servo::ServoState::kEnabled) continue;
    recording.samples.push_back(s);
    if (s.damping_engaged) ++recording.damping_cycles;
    if (s.force_limited) ++recording.force_limited_cycles;
  }
  if (recording.samples.empty()) throw std::runtime_error(log_path + ": no state of a running program");
  return recording;
}

void concatenate_logs(const std::vector<std::string>& parts, const std::string& path) {
  telemetry::LcmLogWriter writer(path);
  for (const std::string& part : parts) {
    lcm::LogFile log(part, "r");
    if (!log.good()) throw std::runtime_error(part + ": cannot open the LCM log");
    while (const lcm::LogEvent* event = log.readNextEvent()) {
      writer.publish(event->channel,
                     std::span<const std::uint8_t>(static_cast<const std::uint8_t*>(event->data),
                                                   static_cast<std::size_t>(event->datalen)),
                     event->timestamp);
    }
  }
  writer.close();
}

}  // namespace clm::commission
