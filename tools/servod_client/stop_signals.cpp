#include "tools/servod_client/stop_signals.hpp"

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <string>
#include <system_error>

namespace clm::servod_client {
namespace {

std::atomic<int> received_signal{0};
static_assert(std::atomic<int>::is_always_lock_free, "the handler writes it");

extern "C" void record_stop_signal(int signal) {
  int none = 0;
  received_signal.compare_exchange_strong(none, signal);  // the first one stays
}

}  // namespace

void install_stop_signals() {
  struct sigaction action {};
  action.sa_handler = record_stop_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;
  for (const int signal : {SIGINT, SIGTERM}) {
    if (::sigaction(signal, &action, nullptr) != 0) {
      throw std::system_error(errno, std::generic_category(), "sigaction");
    }
  }
}

int stop_signal() noexcept { return received_signal.load(std::memory_order_relaxed); }

void throw_if_interrupted() {
  const int signal = stop_signal();
  if (signal == 0) return;
  throw Interrupted(std::string("interrupted by ") + (signal == SIGINT ? "SIGINT" : signal == SIGTERM ? "SIGTERM" : "a signal"));
}

}  // namespace clm::servod_client
