// clm ctl get, set and save (docs/servod.md, "Run-time parameters"):
//   get [KEY]        the value the daemon's cycle uses, of KEY or of every run-time parameter
//   set KEY VALUE    change it at standstill; the daemon checks it as the configuration would
//   save [--config F]  write the running parameters, law and loaded files into F (F.bak keeps the old),
//                      by default the file the daemon was started from; refused for another axis or motor
// Exit status as the other ctl subcommands: 1 refused or no answer, 2 bad
// arguments or a bad configuration file.
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <tuple>
#include <stdexcept>
#include <string>
#include <vector>

#include "clm_lcm/servo_status_t.hpp"
#include "config/yaml_edit.hpp"
#include "daemon/servo/cycle_record.hpp"
#include "daemon/servod/parameters.hpp"
#include "daemon/servod/servod_config.hpp"
#include "tools/cli/ctl_support.hpp"
#include "tools/servod_client/config_update.hpp"

namespace clm::cli {
namespace {

using servod_client::make_command;

/// The value of a get_parameter ack, "key = value unit".
double value_of(const std::string& key, const std::string& text) {
  const std::string prefix = key + " = ";
  double value = 0.0;
  if (text.compare(0, prefix.size(), prefix) == 0) {
    const char* first = text.data() + prefix.size();
    const auto result = std::from_chars(first, text.data() + text.size(), value);
    if (result.ec == std::errc() && result.ptr != first) return value;
  }
  throw std::runtime_error("the daemon answered get_parameter " + key + " with '" + text + "'");
}

/// Every run-time parameter the daemon reports, in the table's order.
std::vector<std::pair<const servod::RuntimeParameter*, double>> get_all(servod_client::Client& client,
                                                                       const CtlOptions& options) {
  std::vector<std::pair<const servod::RuntimeParameter*, double>> out;
  for (const auto& parameter : servod::runtime_parameters()) {
    Command command = make_command(Kind::kGetParameter);
    servod_client::assign_text(command.parameter, parameter.key, "KEY");
    const servod_client::Ack ack = send(client, options, command);
    if (!ack.accepted) throw RunTimeFailure("get_parameter " + std::string(parameter.key) + ": " + ack.text);
    out.emplace_back(&parameter, value_of(parameter.key, ack.text));
  }
  return out;
}

std::string number(double value) {
  char text[32];
  const auto result = std::to_chars(text, text + sizeof text, value);
  return std::string(text, result.ptr);
}

void run_save(const CtlOptions& options, const std::string& requested_path) {
  // Where: the file the daemon was started from, unless told otherwise; what
  // the file must say: the daemon's own axis and motor.
  servod_client::Client client(command_client_options(options));
  const clm_lcm::servo_status_t status = client.wait_for_status(options.timeout_s);
  const std::string config_path = servod_client::daemons_configuration_path(requested_path, status);
  const servod::ServodConfig config = servod::load_servod_config(config_path);
  servod_client::require_daemons_configuration(config, status);
  const auto mode = static_cast<servo::CommutationMode>(status.commutation);  // 0..5: the wire check's range
  if (mode == servo::CommutationMode::kExperiment) {
    throw std::runtime_error("the daemon runs an identification experiment: save once it commutates with a law");
  }
  // Only what differs from the file is written: the rest of it stays as it is.
  const servod::RuntimeValues in_file{config.servo.tuning(), config.control_mass_kg, config.control_bandwidth_hz};
  std::vector<servod_client::ConfigEdit> edits;
  servod::RuntimeValues running = in_file;
  for (const auto& [parameter, value] : get_all(client, options)) {
    const std::string key = parameter->key;
    if (key.rfind("control.feedforward.", 0) == 0) {
      // Below, as a whole.
    } else if (parameter->max > 0.0 && value != servod::parameter_value(in_file, *parameter)) {
      edits.push_back({key, number(value)});  // control.mass_kg (max 0) is fixed at start-up: the file's
    }
    if (key == "control.feedforward.mass_kg") running.tuning.feedforward.mass_kg = value;
    if (key == "control.feedforward.viscous_N_s_per_m") running.tuning.feedforward.viscous_N_s_per_m = value;
    if (key == "control.feedforward.coulomb_N") running.tuning.feedforward.coulomb_N = value;
  }
  const auto same_file = [](const std::string& a, const std::string& b) {
    std::error_code error;
    return !a.empty() && !b.empty() && std::filesystem::equivalent(a, b, error) && !error;
  };
  // The feedforward: the file the daemon loaded while its parameters are in
  // use (the status names it only then), else the numbers.
  const auto& ff = running.tuning.feedforward;
  const auto& ff_file = in_file.tuning.feedforward;
  if (!status.feedforward_file.empty()) {
    if (!same_file(status.feedforward_file, config.feedforward_file)) {
      edits.push_back({"control.feedforward_file", yaml::quoted(status.feedforward_file)});
      edits.push_back({"control.feedforward", std::nullopt});
    }
  } else if (!config.feedforward_file.empty() || ff.mass_kg != ff_file.mass_kg ||
             ff.viscous_N_s_per_m != ff_file.viscous_N_s_per_m || ff.coulomb_N != ff_file.coulomb_N) {
    edits.push_back({"control.feedforward", "{mass_kg: " + number(ff.mass_kg) + ", viscous_N_s_per_m: " +
                                                number(ff.viscous_N_s_per_m) + ", coulomb_N: " + number(ff.coulomb_N) + "}"});
    edits.push_back({"control.feedforward_file", std::nullopt});
  }
  for (const auto& [key, running_file, file] :
       {std::tuple{"commutation.calibration_file", status.calibration_file, config.commutation.calibration_file},
        std::tuple{"commutation.pgnn_model_file", status.pgnn_model_file, config.commutation.pgnn_model_file},
        std::tuple{"commutation.spline_model_file", status.spline_model_file, config.commutation.spline_model_file}}) {
    if (!running_file.empty() && !same_file(running_file, file)) edits.push_back({key, yaml::quoted(running_file)});
  }
  if (config.commutation.mode != mode) edits.push_back({"commutation.mode", servo::name(mode)});
  if (edits.empty()) {
    std::printf("%s already holds the running configuration of axis '%s': nothing written\n", config_path.c_str(),
                status.axis.c_str());
    return;
  }
  const auto update = servod_client::update_config_file(config_path, edits);
  std::printf("saved the running configuration of axis '%s' to %s, %zu change(s) (the previous file is %s)\n",
              status.axis.c_str(), update.path.c_str(), edits.size(), update.backup_path.c_str());
}

}  // namespace

void add_ctl_parameters(CLI::App& ctl, const std::shared_ptr<CtlOptions>& options) {
  auto key = std::make_shared<std::string>();
  auto* get = ctl.add_subcommand("get", "print run-time parameters as the daemon's cycle uses them (all without KEY)");
  get->add_option("KEY", *key, "a run-time parameter, e.g. control.bandwidth_hz (docs/servod.md)");
  get->callback([options, key] {
    servod_client::Client client(command_client_options(*options));
    if (!key->empty()) {
      Command command = make_command(Kind::kGetParameter);
      servod_client::assign_text(command.parameter, *key, "KEY");
      const servod_client::Ack ack = send(client, *options, command);
      require_accepted(ack);
      std::printf("%s\n", ack.text.c_str());
      return;
    }
    for (const auto& [parameter, value] : get_all(client, *options)) {
      std::printf("%s\n", servod::describe_parameter(*parameter, value).c_str());
    }
  });

  struct SetOptions {
    std::string key;
    double value = 0.0;
  };
  auto set = std::make_shared<SetOptions>();
  auto* set_sub = ctl.add_subcommand("set", "change a run-time parameter; the daemon applies it at standstill");
  set_sub->add_option("KEY", set->key, "a run-time parameter, e.g. motion.velocity_m_per_s (docs/servod.md)")->required();
  set_sub->add_option("VALUE", set->value, "the new value, in the parameter's SI unit")->required();
  set_sub->callback([options, set] {
    if (!std::isfinite(set->value)) throw std::runtime_error("VALUE must be finite");
    Command command = make_command(Kind::kSetParameter);
    servod_client::assign_text(command.parameter, set->key, "KEY");
    command.value = set->value;
    send_command(*options, command);
  });

  auto config = std::make_shared<std::string>();
  auto* save = ctl.add_subcommand(
      "save", "write the running parameters, commutation law and loaded files into the daemon's configuration file, "
              "keeping the previous one as FILE.bak; refused for a file of another axis or motor");
  save->add_option("--config", *config,
                   "the file to write (default: the one the daemon was started from, as its status reports)")
      ->check(CLI::ExistingFile);
  save->callback([options, config] { run_save(*options, *config); });
}

}  // namespace clm::cli
