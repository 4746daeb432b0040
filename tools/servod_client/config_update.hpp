#pragma once
// Keeps what was set or commissioned on a running axis: writes values back
// into its clm-servod configuration file (`clm ctl save`, `clm commission
// --save`). The file's text is edited key by key (config/yaml_edit.hpp: its
// comments and layout stay), the result must load as a configuration, the
// previous file is kept beside it as FILE.bak, and both are written
// atomically: an interrupted save leaves either the old file or the new one.

#include <optional>
#include <string>
#include <vector>

#include "clm_lcm/servo_status_t.hpp"
#include "daemon/servod/servod_config.hpp"

namespace clm::servod_client {

/// The configuration file to keep a running daemon's state in: `requested`
/// when not empty, else the file the daemon reports it was started from
/// (its signed status). Throws std::runtime_error when there is none.
std::string daemons_configuration_path(const std::string& requested, const clm_lcm::servo_status_t& status);

/// Throws std::runtime_error naming `config`'s file unless it describes the
/// daemon whose `status` this is: the same axis.name, and a motor_file with
/// the SHA-256 of the motor description the daemon started with.
void require_daemons_configuration(const servod::ServodConfig& config, const clm_lcm::servo_status_t& status);

/// One change: `key` ("section.key") set to `value` (YAML text), or removed.
struct ConfigEdit {
  std::string key;
  std::optional<std::string> value;  ///< nullopt: remove the key
};

struct ConfigUpdate {
  std::string path;         ///< the file written
  std::string backup_path;  ///< the previous content
};

/// Applies `edits` to the configuration file `path`. Throws
/// std::runtime_error naming the file when it cannot be read or written, an
/// edit is refused, or the edited text does not load as a clm-servod
/// configuration (the file is then left untouched, and no backup written).
ConfigUpdate update_config_file(const std::string& path, const std::vector<ConfigEdit>& edits);

}  // namespace clm::servod_client
