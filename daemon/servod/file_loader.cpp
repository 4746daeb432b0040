#include "daemon/servod/file_loader.hpp"

#include <chrono>

namespace clm::servod {

FileLoader::FileLoader() : thread_([this] { run(); }) {}

FileLoader::~FileLoader() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

std::string FileLoader::start(const std::string& path, std::function<void()> job) {
  {
    std::lock_guard lock(mutex_);
    if (busy_.load(std::memory_order_acquire)) return "busy loading " + path_;
    job_ = std::move(job);
    path_ = path;
    busy_.store(true, std::memory_order_release);
  }
  changed_.notify_all();
  return "";
}

bool FileLoader::wait_idle(double timeout_s) const {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, std::chrono::duration<double>(timeout_s),
                           [this] { return !busy_.load(std::memory_order_acquire); });
}

void FileLoader::run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return stop_ || job_; });
    if (!job_) return;  // stop_ and nothing to do
    std::function<void()> job = std::move(job_);
    job_ = nullptr;
    lock.unlock();
    job();  // the job catches what it throws
    lock.lock();
    busy_.store(false, std::memory_order_release);
    changed_.notify_all();
  }
}

}  // namespace clm::servod
