// clm: the command-line tool of clm-servo: calibration, identification,
// feedforward, commutation and (later) commissioning and daemon control.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <iostream>

#include "clm_version.hpp"
#include "tools/cli/commands.hpp"
#include "tools/lcmlog/cmd_log2csv.hpp"

int main(int argc, char** argv) {
  CLI::App app{"clm: commissioning and commutation tools for coreless linear motors"};
  app.set_version_flag("--version", std::string("clm ") + CLM_SERVO_VERSION);
  app.require_subcommand(1);
  clm::cli::add_calibrate(app);
  clm::cli::add_identify(app);
  clm::cli::add_ff_identify(app);
  clm::cli::add_commutate(app);
  clm::cli::add_commission(app);
  clm::lcmlog::add_log2csv(app);
  clm::cli::add_ctl(app);
  clm::cli::add_sim(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();  // a subcommand that has said why on its own (a refusal, several axes)
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);  // --help, --version
    // A bad command line is bad input too: one line (CLI11 would add a second).
    const auto subcommands = app.get_subcommands();
    std::fprintf(stderr, "clm%s%s: error: %s\n", subcommands.empty() ? "" : " ",
                 subcommands.empty() ? "" : subcommands.front()->get_name().c_str(), e.what());
    return e.get_exit_code();
  } catch (const std::exception& e) {
    // One line naming what is wrong and where; nothing was written.
    const auto subcommands = app.get_subcommands();
    std::fprintf(stderr, "clm %s: error: %s\n", subcommands.empty() ? "" : subcommands.front()->get_name().c_str(),
                 e.what());
    return 2;
  }
  return 0;
}
