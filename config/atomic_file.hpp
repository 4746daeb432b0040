#pragma once
// Writes a file so that readers see either the old content or the whole new
// content: a temporary file beside the target, fsync, then rename.

#include <string>

namespace clm {

/// Throws std::runtime_error naming the path and the system error.
void write_file_atomically(const std::string& path, const std::string& content);

}  // namespace clm
