#include "config/command_key.hpp"

#include <sys/stat.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>

#include "config/regular_file.hpp"

namespace clm {
namespace {

constexpr std::size_t kMinKeyBytes = 32;
constexpr std::size_t kMaxKeyBytes = 4096;

}  // namespace

std::string default_command_key_path() {
  const char* named = std::getenv(kCommandKeyEnvironment);
  return named != nullptr && *named != '\0' ? std::string(named) : std::string(kDefaultCommandKeyPath);
}

HmacSha256 load_command_key(const std::string& path) {
  const std::string key = read_regular_file(path, kMaxKeyBytes + 1, " for the command key");
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) throw FileError(path + ": cannot stat the command key");
  if ((info.st_mode & 0007) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(info.st_mode & 07777));
    throw FileError(path + ": the command key has mode " + mode +
                    ", others may read or write it; allow only owner and group (chmod o-rwx)");
  }
  if (key.size() < kMinKeyBytes || key.size() > kMaxKeyBytes) {
    throw FileError(path + ": the command key holds " + std::to_string(key.size()) + " bytes, expected " +
                    std::to_string(kMinKeyBytes) + " to " + std::to_string(kMaxKeyBytes) +
                    " (make one with: head -c 32 /dev/urandom > " + path + ")");
  }
  return HmacSha256(std::span(reinterpret_cast<const std::uint8_t*>(key.data()), key.size()));
}

}  // namespace clm
