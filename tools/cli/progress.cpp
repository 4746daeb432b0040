#include <unistd.h>

#include <cstdio>

#include "clm_version.hpp"
#include "tools/cli/commands.hpp"

namespace clm::cli {

std::string generator_name(const std::string& subcommand) {
  return std::string("clm ") + subcommand + " " + CLM_SERVO_VERSION;
}

ProgressBar::ProgressBar(std::string label) : label_(std::move(label)), terminal_(::isatty(STDERR_FILENO) != 0) {}

void ProgressBar::update(double fraction, const std::string& detail) {
  const int percent = static_cast<int>(100.0 * std::min(1.0, std::max(0.0, fraction)));
  if (terminal_) {
    constexpr int kWidth = 30;
    const int filled = percent * kWidth / 100;
    std::fprintf(stderr, "\r%s [%.*s%*s] %3d%% %s\033[K", label_.c_str(), filled,
                 "##############################", kWidth - filled, "", percent, detail.c_str());
  } else if (percent != last_percent_) {
    std::fprintf(stderr, "%s %3d%% %s\n", label_.c_str(), percent, detail.c_str());
  }
  last_percent_ = percent;
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (terminal_) std::fprintf(stderr, "\n");
}

}  // namespace clm::cli
