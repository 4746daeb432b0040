#include "daemon/telemetry/safety_refusals.hpp"

#include <cstdio>
#include <ctime>

namespace clm::telemetry {
namespace {

constexpr std::int64_t kSecond_us = 1000000;

}  // namespace

std::string utc_time_text(std::int64_t utime) {
  const std::time_t seconds = static_cast<std::time_t>(utime / kSecond_us);
  std::tm parts{};
  gmtime_r(&seconds, &parts);
  char text[48];
  std::snprintf(text, sizeof(text), "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", parts.tm_year + 1900, parts.tm_mon + 1,
                parts.tm_mday, parts.tm_hour, parts.tm_min, parts.tm_sec,
                static_cast<int>((utime % kSecond_us) / 1000));
  return text;
}

void SafetyRefusalLog::roll(std::int64_t utime) noexcept {
  if (utime < window_start_utime_ + kSecond_us) return;
  if (suppressed_ > 0) {
    if (finished_suppressed_ == 0) finished_since_utime_ = window_start_utime_;
    finished_suppressed_ += suppressed_;
  }
  suppressed_ = 0;
  kept_in_window_ = 0;
  window_start_utime_ = utime - utime % kSecond_us;  // whole seconds of the wall clock
}

void SafetyRefusalLog::record(std::int64_t utime, servo::CommandKind kind, std::int64_t client,
                              std::int64_t sequence, servo::CommandResult result, std::string_view reason) noexcept {
  const std::lock_guard lock(mutex_);
  ++recorded_;
  roll(utime);
  if (kept_in_window_ >= kLinesPerSecond || kept_count_ == kept_.size()) {
    ++suppressed_;
    return;
  }
  ++kept_in_window_;
  Entry& entry = kept_[kept_count_++];
  entry.utime = utime;
  entry.kind = kind;
  entry.client = client;
  entry.sequence = sequence;
  entry.result = result;
  if (!entry.reason.assign(reason)) entry.reason.assign(reason.substr(0, 240));
}

std::vector<std::string> SafetyRefusalLog::take_lines(std::int64_t now_utime) {
  std::array<Entry, 2 * kLinesPerSecond> kept;
  std::size_t count = 0;
  std::int64_t suppressed = 0, since_utime = 0;
  {
    const std::lock_guard lock(mutex_);
    roll(now_utime);
    count = kept_count_;
    for (std::size_t k = 0; k < count; ++k) kept[k] = kept_[k];
    kept_count_ = 0;
    suppressed = finished_suppressed_;
    since_utime = finished_since_utime_;
    finished_suppressed_ = 0;
  }
  std::vector<std::string> lines;
  for (std::size_t k = 0; k < count; ++k) {
    const Entry& e = kept[k];
    lines.push_back("refused " + std::string(servo::route(e.kind).name) + " at " + utc_time_text(e.utime) +
                    " from client " + std::to_string(e.client) + " (sequence " + std::to_string(e.sequence) +
                    "): code " + std::to_string(static_cast<int>(e.result)) + ", " + std::string(e.reason.view()));
  }
  if (suppressed > 0) {
    lines.push_back(std::to_string(suppressed) + " more refusals of safety commands suppressed (at most " +
                    std::to_string(kLinesPerSecond) + " a second are logged) since " + utc_time_text(since_utime));
  }
  return lines;
}

std::int64_t SafetyRefusalLog::recorded() const {
  const std::lock_guard lock(mutex_);
  return recorded_;
}

}  // namespace clm::telemetry
