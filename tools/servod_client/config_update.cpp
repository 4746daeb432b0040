#include "tools/servod_client/config_update.hpp"

#include <filesystem>
#include <stdexcept>

#include "config/atomic_file.hpp"
#include "config/regular_file.hpp"
#include "config/yaml_edit.hpp"
#include "config/yaml_reader.hpp"
#include "daemon/servod/servod_config.hpp"

namespace clm::servod_client {

std::string daemons_configuration_path(const std::string& requested, const clm_lcm::servo_status_t& status) {
  if (!requested.empty()) return requested;
  if (status.configuration_file.empty()) {
    throw std::runtime_error("clm-servod's axis '" + status.axis +
                             "' reports no configuration file (its path is too long for the status): give --config");
  }
  return status.configuration_file;
}

void require_daemons_configuration(const servod::ServodConfig& config, const clm_lcm::servo_status_t& status) {
  if (status.axis != config.axis_name) {
    throw std::runtime_error(config.origin + ": axis.name is '" + config.axis_name + "', the daemon answering drives '" +
                             status.axis + "': give the configuration of that daemon");
  }
  if (status.motor_sha256 != config.motor_sha256) {
    throw std::runtime_error(config.origin + ": its motor_file " + config.motor_file + " (SHA-256 " +
                             config.motor_sha256.substr(0, 12) + "…) is not the motor axis '" + status.axis +
                             "' was started with (" + status.motor_file + ", SHA-256 " +
                             status.motor_sha256.substr(0, 12) + "…): give the configuration of that daemon");
  }
}

ConfigUpdate update_config_file(const std::string& path, const std::vector<ConfigEdit>& edits) {
  std::error_code error;
  const std::filesystem::path file = std::filesystem::canonical(path, error);
  if (error) throw std::runtime_error(path + ": " + error.message());
  const std::string before = read_regular_file(file.string(), yaml::Node::kMaxFileBytes);
  std::string after = before;
  for (const ConfigEdit& edit : edits) {
    try {
      after = edit.value ? yaml::set_value(after, edit.key, *edit.value) : yaml::remove_key(after, edit.key);
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(file.string() + ": " + e.what());
    }
  }
  // Loads as the daemon would load it, relative paths against its directory.
  try {
    (void)servod::parse_servod_config(yaml::Node::load_string(after, file.string()), file.parent_path().string());
  } catch (const std::exception& e) {
    throw std::runtime_error(file.string() + ": the edited configuration does not load, left unchanged: " + e.what());
  }
  ConfigUpdate update{file.string(), file.string() + ".bak"};
  write_file_atomically(update.backup_path, before);
  write_file_atomically(update.path, after);
  return update;
}

}  // namespace clm::servod_client
