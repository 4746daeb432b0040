#pragma once
// The command line of every program of clm-servo (clm and its subcommands,
// clm-servod): CLI11 parsing with the exit status convention of
// config/exit_status.hpp and one stderr line per error,
// "<program>[ <subcommand>]: error: <what>".

#include <CLI/CLI.hpp>
#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "config/exit_status.hpp"
#include "config/nearest_name.hpp"

namespace clm {

/// Parses argv with `app` (which runs the subcommands' callbacks), then calls
/// `run` if given, and returns the exit status: `run`'s, or 0 for --help and
/// --version (printed on stdout by CLI11); on an exception one line
/// "<app name>[ <first subcommand>]: error: <what>" on stderr and 1 for
/// RunTimeFailure, 2 for anything else. A mistyped subcommand or long option
/// is named with the nearest one ("unknown subcommand 'comission'; did you
/// mean 'commission'?"). Give `app` its name ("clm") at construction.
int run_command_line(CLI::App& app, int argc, const char* const* argv, const std::function<int()>& run = {});

/// The one-line message of a CLI11 parse error of `app` (after app.parse
/// threw it): an unknown subcommand or option with the nearest known one,
/// else CLI11's own text.
std::string describe_parse_error(const CLI::App& app, const CLI::ParseError& error);


/// Option checks with readable messages (CLI11 prefixes the option's name):
/// "-1 is not > 0", "200 is not in [1, 127]", "'abc' is not a number".
/// Non-finite values (nan, inf) are refused by every one of them.
CLI::Validator positive_number();
CLI::Validator non_negative_number();
CLI::Validator at_least(double min);
CLI::Validator in_range(double min, double max);

}  // namespace clm
