#pragma once
// The terminal `clm scope` draws on: keys without echo or line buffering,
// the alternate screen and a hidden cursor while it runs, all restored when
// it ends (also when it ends by an exception). SIGINT stays a signal.

#include <optional>
#include <string>
#include <termios.h>
#include <vector>

namespace clm::scope {

class Terminal {
 public:
  /// Takes standard input and output, which must both be terminals; throws
  /// std::invalid_argument (bad usage) when they are not.
  Terminal();
  ~Terminal();
  Terminal(const Terminal&) = delete;
  Terminal& operator=(const Terminal&) = delete;

  /// Columns and rows; 80 × 24 when the terminal does not say.
  int columns() const;
  int rows() const;
  /// The next key pressed within `timeout_ms`, or none.
  std::optional<char> read_key(int timeout_ms);
  /// Draws `lines` from the top left, each line cleared to its end.
  void draw(const std::vector<std::string>& lines);

 private:
  termios saved_{};
};

}  // namespace clm::scope
