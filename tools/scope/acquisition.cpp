#include "tools/scope/acquisition.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace clm::scope {

TriggerEdge parse_edge(const std::string& name) {
  if (name == "rising") return TriggerEdge::kRising;
  if (name == "falling") return TriggerEdge::kFalling;
  if (name == "either") return TriggerEdge::kEither;
  throw std::invalid_argument("trigger edge '" + name + "' is not one of rising, falling, either");
}

TriggerMode parse_mode(const std::string& name) {
  if (name == "auto") return TriggerMode::kAuto;
  if (name == "normal") return TriggerMode::kNormal;
  if (name == "single") return TriggerMode::kSingle;
  throw std::invalid_argument("trigger mode '" + name + "' is not one of auto, normal, single");
}

const char* name(TriggerEdge edge) noexcept {
  switch (edge) {
    case TriggerEdge::kRising: return "rising";
    case TriggerEdge::kFalling: return "falling";
    case TriggerEdge::kEither: return "either";
  }
  return "?";
}

const char* name(TriggerMode mode) noexcept {
  switch (mode) {
    case TriggerMode::kAuto: return "auto";
    case TriggerMode::kNormal: return "normal";
    case TriggerMode::kSingle: return "single";
  }
  return "?";
}

const char* name(Phase phase) noexcept {
  switch (phase) {
    case Phase::kFilling: return "filling";
    case Phase::kArmed: return "armed";
    case Phase::kCollecting: return "triggered";
    case Phase::kHeld: return "captured";
    case Phase::kPaused: return "paused";
  }
  return "?";
}

Acquisition::Acquisition(std::size_t channels, double window_s, Trigger trigger)
    : channels_(channels), window_s_(window_s), trigger_(trigger) {
  if (!(window_s > 0.0) || !std::isfinite(window_s)) {
    throw std::invalid_argument("the window must be a time above 0 s, not " + std::to_string(window_s));
  }
  if (trigger.channel >= static_cast<int>(channels)) {
    throw std::invalid_argument("trigger channel " + std::to_string(trigger.channel) + " of " +
                                std::to_string(channels) + " channels");
  }
  if (!(trigger.pre_trigger >= 0.0 && trigger.pre_trigger <= 1.0)) {
    throw std::invalid_argument("the pre-trigger fraction must be within 0..1, not " +
                                std::to_string(trigger.pre_trigger));
  }
}

void Acquisition::push(double t_s, std::int64_t sequence, std::span<const double> values) {
  if (phase_ == Phase::kPaused || !std::isfinite(t_s) || values.size() != channels_) return;
  if (!history_.empty() && (!(t_s > history_.back().t_s) || sequence <= history_.back().sequence)) {
    // Time went back: another run of the daemon, or the next one in a log.
    history_.clear();
    if (phase_ == Phase::kCollecting) phase_ = Phase::kArmed;
    armed_at_s_ = std::numeric_limits<double>::quiet_NaN();
    next_allowed_s_ = -std::numeric_limits<double>::infinity();
  }
  history_.push_back(Sample{t_s, sequence, std::vector<double>(values.begin(), values.end())});
  if (std::isnan(armed_at_s_)) armed_at_s_ = t_s;
  if (phase_ == Phase::kArmed) look_for_trigger();
  if (phase_ == Phase::kCollecting && t_s >= trigger_t_s_ + post_s()) {
    shown_ = cut(trigger_t_s_ - pre_s(), trigger_t_s_);
    shown_.number = ++captures_;
    roll_due_ = false;
    next_allowed_s_ = trigger_t_s_ + post_s();
    phase_ = trigger_.mode == TriggerMode::kSingle ? Phase::kHeld : Phase::kArmed;
  }
  // Auto: without a trigger for a window's length, show the latest window.
  const double since_s = t_s - std::max(armed_at_s_, next_allowed_s_);
  if (phase_ == Phase::kArmed && trigger_.mode == TriggerMode::kAuto && since_s >= window_s_) roll_due_ = true;
  trim();
}

Phase Acquisition::phase() const {
  if (phase_ != Phase::kArmed) return phase_;
  return !history_.empty() && may_trigger_at(history_.back().t_s) ? Phase::kArmed : Phase::kFilling;
}

const Window& Acquisition::shown() const {
  if (roll_due_ && !history_.empty()) {
    shown_ = cut(history_.back().t_s - window_s_, std::numeric_limits<double>::quiet_NaN());
    roll_due_ = false;
  }
  return shown_;
}

void Acquisition::look_for_trigger() {
  if (trigger_.channel < 0 || history_.size() < 2) return;
  const Sample& before = history_[history_.size() - 2];
  const Sample& now = history_.back();
  const auto c = static_cast<std::size_t>(trigger_.channel);
  const double a = before.values[c], b = now.values[c], level = trigger_.level;
  const bool rising = a < level && b >= level;
  const bool falling = a > level && b <= level;
  const bool crossed = trigger_.edge == TriggerEdge::kRising    ? rising
                       : trigger_.edge == TriggerEdge::kFalling ? falling
                                                                : rising || falling;
  if (!crossed) return;  // NaN compares false: never crosses
  const double t_s = before.t_s + (level - a) / (b - a) * (now.t_s - before.t_s);
  // The part before the trigger must have been recorded since arming, and
  // a window never starts inside the previous one's part after its trigger.
  if (!may_trigger_at(t_s)) return;
  trigger_t_s_ = t_s;
  phase_ = Phase::kCollecting;
}

Window Acquisition::cut(double start_s, double trigger_t_s) const {
  Window w;
  w.start_s = start_s;
  w.length_s = window_s_;
  w.trigger_t_s = trigger_t_s;
  w.values.resize(channels_);
  const double end_s = start_s + window_s_;
  // Sequence steps in double: a hostile cycle number cannot overflow them.
  double step = std::numeric_limits<double>::infinity();
  for (std::size_t k = 1; k < history_.size(); ++k) {
    step = std::min(step, static_cast<double>(history_[k].sequence) - static_cast<double>(history_[k - 1].sequence));
  }
  for (std::size_t k = 0; k < history_.size(); ++k) {
    const Sample& s = history_[k];
    if (k > 0) {
      // The n states missing between this sample and the one before, spread
      // evenly in time (the j-th at before + j·dt/(n+1)): those within the window.
      const Sample& before = history_[k - 1];
      const double n =
          std::round((static_cast<double>(s.sequence) - static_cast<double>(before.sequence)) / step) - 1.0;
      const double dt = s.t_s - before.t_s;
      if (step > 0.0 && n >= 1.0 && std::isfinite(n)) {
        const double first = std::max(1.0, std::ceil((start_s - before.t_s) / dt * (n + 1.0)));
        const double last = std::min(n, std::floor((end_s - before.t_s) / dt * (n + 1.0)));
        if (last >= first) w.missing += static_cast<std::int64_t>(std::min(last - first + 1.0, 1e15));
      }
    }
    if (s.t_s < start_s || s.t_s > end_s) continue;
    w.t_s.push_back(s.t_s);
    for (std::size_t c = 0; c < channels_; ++c) w.values[c].push_back(s.values[c]);
  }
  return w;
}

void Acquisition::trim() {
  // Kept: two windows, enough for the part before any trigger still to come
  // and for a rolling window.
  const double keep_from_s = history_.back().t_s - 2.0 * window_s_;
  while (history_.size() > 2 && history_.front().t_s < keep_from_s) history_.pop_front();
}

void Acquisition::set_paused(bool paused) {
  if (paused) {
    phase_ = Phase::kPaused;
  } else if (phase_ == Phase::kPaused) {
    arm();
  }
}

void Acquisition::arm() {
  phase_ = Phase::kArmed;
  armed_at_s_ = std::numeric_limits<double>::quiet_NaN();
  next_allowed_s_ = -std::numeric_limits<double>::infinity();
}

void Acquisition::set_mode(TriggerMode mode) {
  trigger_.mode = mode;
  arm();
}

void Acquisition::set_level(double level) {
  trigger_.level = level;
  if (phase_ == Phase::kCollecting) phase_ = Phase::kArmed;
}

void Acquisition::set_edge(TriggerEdge edge) {
  trigger_.edge = edge;
  if (phase_ == Phase::kCollecting) phase_ = Phase::kArmed;
}

void Acquisition::set_window(double window_s) {
  if (!(window_s > 0.0) || !std::isfinite(window_s)) return;
  window_s_ = window_s;
  if (phase_ != Phase::kPaused) arm();
}

}  // namespace clm::scope

namespace clm::scope {

double step_window(double window_s, int steps) {
  // The time bases 1 ms, 2 ms, 5 ms, 10 ms, ... 100 s.
  std::vector<double> bases;
  for (double decade = 1e-3; decade < 150.0; decade *= 10.0) {
    for (double mantissa : {1.0, 2.0, 5.0}) {
      if (mantissa * decade <= 100.0 * (1.0 + 1e-9)) bases.push_back(mantissa * decade);
    }
  }
  int k = 0;  // the largest base not above window_s
  while (k + 1 < static_cast<int>(bases.size()) && bases[static_cast<std::size_t>(k + 1)] <= window_s * (1.0 + 1e-9)) ++k;
  const bool off = bases[static_cast<std::size_t>(k)] < window_s * (1.0 - 1e-9);
  if (off && steps < 0) ++steps;  // off the sequence: the first step down is to that base
  k = std::clamp(k + steps, 0, static_cast<int>(bases.size()) - 1);
  return bases[static_cast<std::size_t>(k)];
}

}  // namespace clm::scope
