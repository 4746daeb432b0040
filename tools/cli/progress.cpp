#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

#include "clm_version.hpp"
#include "tools/cli/progress.hpp"

namespace clm::cli {

std::string generator_name(const std::string& subcommand) {
  return std::string("clm ") + subcommand + " " + CLM_SERVO_VERSION;
}

ProgressBar::ProgressBar(std::string label)
    : label_(std::move(label)), terminal_(::isatty(STDERR_FILENO) != 0), start_(std::chrono::steady_clock::now()) {}

// The time left of a step, extrapolated from its elapsed time and the
// fraction done; empty until both say enough (2 s and 5 %).
static std::string time_left(double elapsed_s, double fraction) {
  if (elapsed_s < 2.0 || fraction < 0.05 || fraction >= 1.0) return "";
  const double left_s = elapsed_s * (1.0 - fraction) / fraction;
  char text[48];
  std::snprintf(text, sizeof text, ", about %.0f s left", std::min(left_s, 1e6));
  return text;
}

void ProgressBar::update(double fraction, const std::string& detail) {
  fraction = std::min(1.0, std::max(0.0, fraction));
  const int percent = static_cast<int>(100.0 * fraction);
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const std::string left = time_left(elapsed_s, fraction);
  if (terminal_) {
    constexpr int kWidth = 30;
    const int filled = percent * kWidth / 100;
    std::fprintf(stderr, "\r%s [%.*s%*s] %3d%% %s%s\033[K", label_.c_str(), filled,
                 "##############################", kWidth - filled, "", percent, detail.c_str(), left.c_str());
  } else if (percent != last_percent_) {
    std::fprintf(stderr, "%s %3d%% %s%s\n", label_.c_str(), percent, detail.c_str(), left.c_str());
  }
  last_percent_ = percent;
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (terminal_) std::fprintf(stderr, "\n");
}

}  // namespace clm::cli
