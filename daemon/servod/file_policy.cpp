#include "daemon/servod/file_policy.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

namespace clm::servod {

std::string check_loadable(const FilePolicy& policy, const std::string& path, std::string& canonical) {
  if (path.empty()) return "no file named";
  if (path.front() != '/') return "'" + path + "': give an absolute path";
  std::error_code error;
  const std::filesystem::path resolved = std::filesystem::canonical(path, error);
  if (error) return "'" + path + "': " + error.message();
  const std::string text = resolved.string();
  bool inside = false;
  for (const std::string& directory : policy.directories) {
    if (text.size() > directory.size() && text.compare(0, directory.size(), directory) == 0 &&
        (directory.back() == '/' || text[directory.size()] == '/')) {
      inside = true;
      break;
    }
  }
  if (!inside) return "'" + path + "': outside the directories commands may load from (commands.file_directories)";
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

}  // namespace clm::servod
