#pragma once
// Writing telemetry as an LCM log file.

#include <cstdint>
#include <memory>
#include <string>

#include "daemon/telemetry/sink.hpp"

namespace lcm {
class LogFile;
}

namespace clm::telemetry {

/// Writes every message as an event of an LCM log (readable by lcm-logplayer,
/// lcm-spy's log player and tools/lcmlog). Writes `path`.tmp and renames it
/// to `path` in close(), so a crash or an error never leaves a partial log
/// under the final name.
class LcmLogWriter : public TelemetrySink {
 public:
  /// Opens `path`.tmp; throws std::runtime_error naming it.
  explicit LcmLogWriter(std::string path);
  /// Without a successful close() the log stays under `path`.tmp, as a crash
  /// would leave it.
  ~LcmLogWriter() override;
  LcmLogWriter(const LcmLogWriter&) = delete;
  LcmLogWriter& operator=(const LcmLogWriter&) = delete;

  /// Throws std::runtime_error naming the file and the event on a write
  /// error; the log is then never renamed into place.
  void publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t utime) override;
  /// Flushes and fsyncs `path`.tmp and renames it to `path`. Throws
  /// std::runtime_error after any write error (the .tmp stays). Idempotent.
  void close();

  const std::string& path() const { return path_; }
  std::int64_t events_written() const { return events_written_; }

 private:
  std::string path_;
  std::string temporary_path_;
  std::unique_ptr<lcm::LogFile> log_;
  std::int64_t events_written_ = 0;
  std::string error_;
  bool closed_ = false;
};

/// Writes the marker of a recorder that resumes recording after leaving
/// cycles out on purpose: a servo_event_t with code kRecordingResumedEvent,
/// `cycle` the daemon's last cycle before it as far as the recorder knows,
/// stamped `utime`. A reader of the log
/// (tools/lcmlog) then takes the step in the cycle counter across the marker
/// for a pause, not a loss. Throws as `sink`.publish does.
void mark_recording_resumed(TelemetrySink& sink, std::int64_t cycle, std::int64_t utime);

}  // namespace clm::telemetry
