#pragma once
// Argument checks shared by the offline (throwing) functions of clm::control.
// Internal to the library; not part of its API.

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace clm::control::detail {

/// A double with enough digits to identify it in an error message.
inline std::string format_number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", value);
  return text;
}

/// Throws std::invalid_argument "<context>: <name> must be positive and finite, got <value>".
/// −1, 0 or +1.
inline double sign(double value) noexcept { return static_cast<double>((value > 0.0) - (value < 0.0)); }

inline void require_positive_finite(const char* context, const char* name, double value) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string(context) + ": " + name + " must be positive and finite, got " +
                                format_number(value));
  }
}

/// Throws std::invalid_argument "<context>: <name> must be finite, got <value>".
inline void require_finite(const char* context, const char* name, double value) {
  if (!std::isfinite(value)) {
    throw std::invalid_argument(std::string(context) + ": " + name + " must be finite, got " + format_number(value));
  }
}

}  // namespace clm::control::detail
