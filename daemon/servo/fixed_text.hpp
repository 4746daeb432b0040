#pragma once
// Text in a fixed char array, always NUL-terminated: what the cycle and its
// queues can carry without allocating.

#include <array>
#include <cstddef>
#include <string_view>

namespace clm::servo {

template <std::size_t N>
struct FixedText {
  static_assert(N >= 2);
  static constexpr std::size_t kMaxChars = N - 1;

  std::array<char, N> chars{};

  /// Copies `text`. False if it is longer than kMaxChars; then the first
  /// kMaxChars characters are kept (callers that must not cut, refuse).
  bool assign(std::string_view text) noexcept {
    const std::size_t count = text.size() < kMaxChars ? text.size() : kMaxChars;
    for (std::size_t i = 0; i < count; ++i) chars[i] = text[i];
    chars[count] = '\0';
    return count == text.size();
  }
  std::string_view view() const noexcept { return std::string_view(chars.data()); }
  bool empty() const noexcept { return chars[0] == '\0'; }
};

/// File paths in commands and status: up to 255 characters.
using PathText = FixedText<256>;

}  // namespace clm::servo
