#pragma once
// Progress of the tools' long steps, and the tools' name in provenance
// records (without CLI11, which the subcommands' files alone need).

#include <chrono>
#include <string>

namespace clm::cli {

/// "clm <version>" for provenance records.
std::string generator_name(const std::string& subcommand);

/// Progress of a long step on stderr: a bar on a terminal, one line per
/// update otherwise.
class ProgressBar {
 public:
  explicit ProgressBar(std::string label);
  void update(double fraction, const std::string& detail);
  void finish();

 private:
  std::string label_;
  bool terminal_;
  int last_percent_ = -1;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace clm::cli
