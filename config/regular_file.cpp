#include "config/regular_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

namespace clm {
namespace {

const char* kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "neither a file nor a directory";
}

[[noreturn]] void refuse_kind(const std::string& path, mode_t mode) {
  throw FileError(path + ": not a regular file (" + kind_of(mode) + "); only regular files are read");
}

[[noreturn]] void refuse_size(const std::string& path, std::uint64_t size, std::uint64_t max_bytes,
                              std::string_view limit_note, const char* how) {
  throw FileError(path + ": " + how + std::to_string(size) + " bytes, more than the limit of " +
                  std::to_string(max_bytes) + " bytes" + std::string(limit_note));
}

}  // namespace

RegularFile::RegularFile(std::string path, int fd, std::uint64_t size_bytes)
    : path_(std::move(path)), fd_(fd), size_bytes_(size_bytes) {}

RegularFile::RegularFile(RegularFile&& other) noexcept
    : path_(std::move(other.path_)), fd_(std::exchange(other.fd_, -1)), size_bytes_(other.size_bytes_) {}

RegularFile& RegularFile::operator=(RegularFile&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    path_ = std::move(other.path_);
    fd_ = std::exchange(other.fd_, -1);
    size_bytes_ = other.size_bytes_;
  }
  return *this;
}

RegularFile::~RegularFile() {
  if (fd_ >= 0) ::close(fd_);
}

std::size_t RegularFile::read(void* buffer, std::size_t count) {
  auto* out = static_cast<char*>(buffer);
  std::size_t done = 0;
  while (done < count) {
    const ssize_t got = ::read(fd_, out + done, count - done);
    if (got < 0) {
      if (errno == EINTR) continue;
      throw FileError(path_ + ": read error: " + std::strerror(errno));
    }
    if (got == 0) break;
    done += static_cast<std::size_t>(got);
  }
  return done;
}

RegularFile open_regular_file(const std::string& path, std::uint64_t max_bytes, std::string_view limit_note) {
  // Look before opening: opening some devices has effects of its own (a tape
  // rewinds, a terminal may become the controlling one); a socket cannot be
  // opened at all and would only say "No such device or address".
  struct stat before {};
  if (::stat(path.c_str(), &before) == 0 && !S_ISREG(before.st_mode)) refuse_kind(path, before.st_mode);
  // O_NONBLOCK: should the path have become a FIFO since, open returns at once
  // rather than waiting for a writer; fstat below then refuses it.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
  if (fd < 0) throw FileError(path + ": cannot open: " + std::strerror(errno));
  RegularFile file(path, fd, 0);
  struct stat status {};
  if (::fstat(fd, &status) != 0) throw FileError(path + ": cannot stat: " + std::strerror(errno));
  if (!S_ISREG(status.st_mode)) refuse_kind(path, status.st_mode);
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  file.size_bytes_ = static_cast<std::uint64_t>(status.st_size);
  if (file.size_bytes_ > max_bytes) refuse_size(path, file.size_bytes_, max_bytes, limit_note, "");
  return file;
}

std::string read_regular_file(const std::string& path, std::uint64_t max_bytes, std::string_view limit_note) {
  RegularFile file = open_regular_file(path, max_bytes, limit_note);
  std::string content;
  // One allocation of the size fstat gave (plus the byte that shows the end);
  // the loop grows the string only if the file grew since.
  content.resize(static_cast<std::size_t>(file.size_bytes()) + 1);
  std::size_t used = 0;
  while (true) {
    if (used == content.size()) {
      if (used > max_bytes) refuse_size(path, used, max_bytes, limit_note, "grew while read to at least ");
      content.resize(std::max<std::size_t>(content.size() * 2, 4096));
    }
    const std::size_t got = file.read(content.data() + used, content.size() - used);
    used += got;
    if (got == 0) break;
  }
  if (used > max_bytes) refuse_size(path, used, max_bytes, limit_note, "grew while read to ");
  content.resize(used);  // no shrink_to_fit: it would copy the whole file for one byte
  return content;
}

}  // namespace clm
