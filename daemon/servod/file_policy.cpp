#include "daemon/servod/file_policy.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

namespace clm::servod {
namespace {

/// `canonical` lies below one of the policy's directories.
bool inside(const FilePolicy& policy, const std::string& canonical) {
  for (const std::string& directory : policy.directories) {
    if (canonical.size() > directory.size() && canonical.compare(0, directory.size(), directory) == 0 &&
        (directory.back() == '/' || canonical[directory.size()] == '/')) {
      return true;
    }
  }
  return false;
}

}  // namespace

std::string check_loadable(const FilePolicy& policy, const std::string& path, std::string& canonical) {
  if (path.empty()) return "no file named";
  if (path.front() != '/') return "'" + path + "': give an absolute path";
  std::error_code error;
  const std::filesystem::path resolved = std::filesystem::canonical(path, error);
  if (error) return "'" + path + "': " + error.message();
  const std::string text = resolved.string();
  if (!inside(policy, text)) return "'" + path + "': outside the directories commands may load from (commands.file_directories)";
  struct stat info {};
  if (::stat(text.c_str(), &info) != 0) return "'" + path + "': " + std::strerror(errno);
  if (!S_ISREG(info.st_mode)) return "'" + path + "': not a regular file";
  if (info.st_size > policy.max_file_bytes) {
    return "'" + path + "': " + std::to_string(info.st_size) + " bytes, over the limit of " +
           std::to_string(policy.max_file_bytes) + " (commands.max_file_bytes)";
  }
  canonical = text;
  return "";
}

std::string check_output_directory(const FilePolicy& policy, const std::string& directory) {
  std::error_code error;
  const std::filesystem::path resolved = std::filesystem::weakly_canonical(std::filesystem::absolute(directory), error);
  if (error) return "'" + directory + "': " + error.message();
  // A file in it: the directory itself may be one of the policy's.
  if (inside(policy, (resolved / "file").string())) return "";
  std::string allowed;
  for (const std::string& d : policy.directories) allowed += (allowed.empty() ? "" : ", ") + d;
  return "'" + directory + "' (" + resolved.string() + ") is outside the directories the daemon may load from (" +
         allowed + ", its commands.file_directories): choose --out inside one of them, or add one to the daemon's "
         "configuration";
}

}  // namespace clm::servod
