#include "daemon/telemetry/lcm_log_writer.hpp"

#include <lcm/lcm-cpp.hpp>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "daemon/telemetry/lcm_conversion.hpp"
#include "daemon/telemetry/messages.hpp"

namespace clm::telemetry {

LcmLogWriter::LcmLogWriter(std::string path) : path_(std::move(path)), temporary_path_(path_ + ".tmp") {
  errno = 0;
  log_ = std::make_unique<lcm::LogFile>(temporary_path_, "w");
  if (!log_->good()) {
    const int error = errno;
    throw std::runtime_error(temporary_path_ + ": cannot open for writing" +
                             (error != 0 ? std::string(": ") + std::strerror(error) : std::string()));
  }
}

LcmLogWriter::~LcmLogWriter() = default;

void LcmLogWriter::publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t utime) {
  if (closed_) throw std::logic_error(path_ + ": log already closed");
  if (!error_.empty()) throw std::runtime_error(error_);
  lcm::LogEvent event{};
  event.timestamp = stamped(utime);
  event.channel = std::string(channel);
  event.datalen = static_cast<std::int32_t>(data.size());
  event.data = const_cast<std::uint8_t*>(data.data());  // LogEvent is shared with reading; writing does not modify
  if (log_->writeEvent(&event) != 0) {
    error_ = temporary_path_ + ": event " + std::to_string(events_written_) + ": write failed: " + std::strerror(errno);
    throw std::runtime_error(error_);
  }
  ++events_written_;
}

void LcmLogWriter::close() {
  if (closed_) return;
  if (!error_.empty()) throw std::runtime_error(error_ + "; the partial log stays at " + temporary_path_);
  FILE* file = log_->getFilePtr();
  if (std::fflush(file) != 0 || ::fsync(::fileno(file)) != 0) {
    error_ = temporary_path_ + ": cannot flush: " + std::strerror(errno);
    throw std::runtime_error(error_);
  }
  log_.reset();  // fclose
  if (std::rename(temporary_path_.c_str(), path_.c_str()) != 0) {
    error_ = path_ + ": cannot rename " + temporary_path_ + " into place: " + std::strerror(errno);
    throw std::runtime_error(error_);
  }
  closed_ = true;
}

void mark_recording_resumed(TelemetrySink& sink, std::int64_t cycle, std::int64_t utime) {
  ServoEventSample marker;
  marker.utime = utime;
  marker.cycle = cycle;
  marker.code = kRecordingResumedEvent;
  marker.severity = clm_lcm::servo_event_t::SEVERITY_INFO;
  marker.text.assign("recording resumed: the cycles before were left out on purpose");
  publish_message(sink, kEventChannel, to_message(marker), utime);
}

}  // namespace clm::telemetry
