#pragma once
// Which files a command may make clm-servod read (docs/servod.md, "Files").
// A model, calibration, feedforward or program file named in a command is
// read only when its canonical path (symbolic links and ".." resolved) lies
// inside one of the configured directories, it is a regular file, and it is
// no larger than the configured limit. A refusal names the path as sent and
// the rule it broke; it never contains anything read from the file.

#include <cstdint>
#include <string>
#include <vector>

namespace clm::servod {

struct FilePolicy {
  std::vector<std::string> directories;  ///< canonical absolute directories
  std::int64_t max_file_bytes = 16 << 20;
};

/// Checks `path` against `policy`. Returns "" and sets `canonical` to the path
/// to open, or returns the one-line refusal. Touches the file system (stat,
/// realpath), never reads the file.
std::string check_loadable(const FilePolicy& policy, const std::string& path, std::string& canonical);

/// Whether files that will be written into `directory` (which need not exist
/// yet) will load under `policy`: "" or the one-line refusal naming the
/// directory, the allowed ones and the fix. For tools that write what the
/// daemon is to load (`clm commission --live --out`).
std::string check_output_directory(const FilePolicy& policy, const std::string& directory);

}  // namespace clm::servod
