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

namespace clm::servod_client {

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
