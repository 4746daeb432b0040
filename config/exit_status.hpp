#pragma once
// The exit status of every program of clm-servo (clm and its subcommands,
// clm-servod; docs/design-decisions.md, "Exit status and error messages"):
//   0  success, and --help and --version;
//   1  refused or failed at run time (a command refused, no answer in time,
//      the servo loop failed): RunTimeFailure;
//   2  bad usage or bad input: a bad command line, a bad or unreadable
//      configuration or data file (every other exception).
// config/command_line.hpp maps exceptions to these and prints the one line.

#include <stdexcept>

namespace clm {

inline constexpr int kExitSuccess = 0;
inline constexpr int kExitFailure = 1;   ///< refused or failed at run time
inline constexpr int kExitBadInput = 2;  ///< bad usage, bad or unreadable input

/// A failure at run time, not of the input: a refusal, a timeout. The
/// program prints what() as its one error line and exits kExitFailure.
class RunTimeFailure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace clm
