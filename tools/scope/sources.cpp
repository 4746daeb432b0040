#include "tools/scope/sources.hpp"

#include <algorithm>
#include <cstdio>

#include "daemon/telemetry/lcm_conversion.hpp"
#include "daemon/telemetry/telemetry.hpp"
#include "tools/lcmlog/servo_log.hpp"
#include "tools/servod_client/client.hpp"

namespace clm::scope {

namespace {

class LiveSource final : public StateSource {
 public:
  LiveSource(const std::string& lcm_url, const std::string& key_file)
      : client_([&] {
          servod_client::Options options;
          options.lcm_url = lcm_url;
          options.channels = telemetry::kStateChannel;
          options.every_state = true;
          options.key_file = key_file;
          return options;
        }()) {
    client_.start_capture();
  }

  void take(std::vector<servo::CycleRecord>& out) override {
    for (const auto& message : client_.take_captured()) {
      clm_lcm::servo_state_t state;
      if (message.channel == telemetry::kStateChannel && servod_client::decode(message.data, state)) {
        out.push_back(telemetry::to_record(state));
      }
    }
  }

  bool exhausted() const override { return false; }

  std::string describe() const override {
    std::string text = "live " + client_.lcm_url();
    const std::int64_t dropped = client_.unauthenticated() + client_.undecodable();
    if (dropped > 0) text += " (" + std::to_string(dropped) + " foreign or damaged messages dropped)";
    return text;
  }

 private:
  servod_client::Client client_;
};

class LogSource final : public StateSource {
 public:
  LogSource(const std::string& path, double speed) : path_(path), speed_(speed), states_(lcmlog::read_servo_states(path)) {
    // The time each state is due, from the first: the log's own steps, a
    // gap above 1 s or a step back played as the step before it.
    due_s_.resize(states_.size(), 0.0);
    double step_s = 0.0;
    for (std::size_t k = 1; k < states_.size(); ++k) {
      const double dt = states_[k].t_s - states_[k - 1].t_s;
      if (dt > 0.0 && dt <= 1.0) step_s = dt;
      due_s_[k] = due_s_[k - 1] + step_s;
    }
  }

  void take(std::vector<servo::CycleRecord>& out) override {
    const auto now = std::chrono::steady_clock::now();
    if (!started_) {
      started_ = true;
      start_ = now;
    }
    const double played_s = std::chrono::duration<double>(now - start_).count() * speed_;
    while (next_ < states_.size() && (speed_ <= 0.0 || due_s_[next_] <= played_s)) out.push_back(states_[next_++]);
  }

  bool exhausted() const override { return next_ >= states_.size(); }

  std::string describe() const override {
    char speed[32];
    std::snprintf(speed, sizeof(speed), "%g", speed_);
    return "log " + path_ + (speed_ > 0.0 ? " at " + std::string(speed) + "x" : " (all at once)") + ", state " +
           std::to_string(next_) + " of " + std::to_string(states_.size());
  }

 private:
  std::string path_;
  double speed_;
  std::vector<servo::CycleRecord> states_;
  std::vector<double> due_s_;
  std::size_t next_ = 0;
  bool started_ = false;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace

std::unique_ptr<StateSource> live_source(const std::string& lcm_url, const std::string& key_file) {
  return std::make_unique<LiveSource>(lcm_url, key_file);
}

std::unique_ptr<StateSource> log_source(const std::string& path, double speed) {
  return std::make_unique<LogSource>(path, speed);
}

}  // namespace clm::scope
