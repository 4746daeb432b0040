#pragma once
// Input files read without trusting them: only a regular file is read (a FIFO
// without a writer, a device such as /dev/zero, a directory or a socket named
// by mistake is refused at once, without blocking), and no more bytes than a
// stated limit (docs/data-formats.md, "Size limits"). Every reader of the
// tools and the daemon goes through here: YAML, CSV, LCM logs, file hashes.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>

namespace clm {

/// A refused or unreadable input file: one line naming the file and the rule,
/// e.g. "run.csv: not a regular file (a FIFO); only regular files are read".
class FileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// No limit on the size of a file (hashing a file already read, for instance).
inline constexpr std::uint64_t kUnlimitedBytes = std::numeric_limits<std::uint64_t>::max();

/// A regular file open for reading; closes it when destroyed.
class RegularFile {
 public:
  RegularFile(RegularFile&& other) noexcept;
  RegularFile& operator=(RegularFile&& other) noexcept;
  RegularFile(const RegularFile&) = delete;
  RegularFile& operator=(const RegularFile&) = delete;
  ~RegularFile();

  const std::string& path() const { return path_; }
  /// Size in bytes when it was opened (fstat).
  std::uint64_t size_bytes() const { return size_bytes_; }
  /// Reads up to `count` bytes, fewer only at the end of the file; 0 at the
  /// end. Throws FileError naming the path on a read error.
  std::size_t read(void* buffer, std::size_t count);

 private:
  friend RegularFile open_regular_file(const std::string&, std::uint64_t, std::string_view);
  RegularFile(std::string path, int fd, std::uint64_t size_bytes);
  std::string path_;
  int fd_ = -1;
  std::uint64_t size_bytes_ = 0;
};

/// Opens `path` for reading (O_NONBLOCK, so that nothing blocks before the
/// check; fstat; S_ISREG). Throws FileError with one line:
///   "<path>: cannot open: No such file or directory"
///   "<path>: not a regular file (a FIFO); only regular files are read"
///   "<path>: 3000000000 bytes, more than the limit of 1073741824 bytes<limit_note>"
/// `limit_note` says what the limit is for and how to raise it, e.g.
/// " for data files (--max-bytes raises it)".
RegularFile open_regular_file(const std::string& path, std::uint64_t max_bytes, std::string_view limit_note = {});

/// The whole content of the regular file at `path`, at most `max_bytes` even
/// if it grows while read (files of /proc report size 0: read to the end).
/// Throws FileError as open_regular_file, and on a read error.
std::string read_regular_file(const std::string& path, std::uint64_t max_bytes, std::string_view limit_note = {});

}  // namespace clm
