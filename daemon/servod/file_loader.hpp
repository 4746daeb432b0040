#pragma once
// clm-servod's loader thread (docs/servod.md, "Files"): reads the files that
// commands name (models, calibrations, feedforward, programs) one at a time,
// off the command thread, so that a slow or large file never delays the
// answer to another command. The daemon core hands it one job at a time and
// collects the job's result itself (ServoDaemon::take_replies).

#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace clm::servod {

class FileLoader {
 public:
  /// Starts the loader thread.
  FileLoader();
  /// Joins the thread: waits for a running job (see wait_idle, abandon).
  ~FileLoader();
  FileLoader(const FileLoader&) = delete;
  FileLoader& operator=(const FileLoader&) = delete;

  /// Runs `job` on the loader thread. Returns "" when it was started, else
  /// "busy loading <path>" naming the file of the job still running.
  std::string start(const std::string& path, std::function<void()> job);
  /// True while a job runs (or waits to run).
  bool busy() const noexcept { return busy_.load(std::memory_order_acquire); }
  /// Waits at most `timeout_s` for the running job to end; true when none runs.
  bool wait_idle(double timeout_s) const;

 private:
  void run();

  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::function<void()> job_;
  std::string path_;
  std::atomic<bool> busy_{false};
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace clm::servod
