#pragma once
// clm log2csv: the CLM_SERVO_STATE messages of an LCM log as CSV, in the
// column set of the tool that reads it next (docs/telemetry.md).

#include <CLI/CLI.hpp>

namespace clm::lcmlog {

/// Registers `log2csv --log FILE --output FILE.csv --format experiment|feedforward|full`
/// on `app`. Its callback throws std::exception with one line naming the log
/// file and the event on bad input; the CSV is written atomically, or not at all.
void add_log2csv(CLI::App& app);

}  // namespace clm::lcmlog
