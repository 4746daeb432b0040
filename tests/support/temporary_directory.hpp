#pragma once
// A fresh directory of a test's own under the system's temporary directory.

#include <string>

namespace clm::test {

/// Creates `<temp>/<stem>-XXXXXX` (mkdtemp: a new name, mode 0700) and
/// removes it with everything in it on destruction. Throws
/// std::runtime_error naming the path when it cannot be created.
class TemporaryDirectory {
 public:
  explicit TemporaryDirectory(const std::string& stem = "clm_test");
  ~TemporaryDirectory();
  TemporaryDirectory(const TemporaryDirectory&) = delete;
  TemporaryDirectory& operator=(const TemporaryDirectory&) = delete;

  const std::string& path() const { return path_; }
  /// `name` inside the directory (not created).
  std::string file(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

}  // namespace clm::test
