// clm: the command-line tool of clm-servo: calibration, identification,
// feedforward, commutation, commissioning, daemon control and the simulated
// motor on CAN.
//
// Exit status (config/command_line.hpp): 0 success; 1 refused or failed at
// run time (clm::RunTimeFailure: a command refused, no answer in time); 2 bad
// usage or bad input (a bad command line, a bad or unreadable file). One line
// on stderr per error: "clm <subcommand>: error: <what>".

#include <CLI/CLI.hpp>
#include <string>

#include "clm_version.hpp"
#include "config/command_line.hpp"
#include "tools/cli/commands.hpp"
#include "tools/lcmlog/cmd_log2csv.hpp"

int main(int argc, char** argv) {
  CLI::App app{"clm: commissioning and commutation tools for coreless linear motors", "clm"};
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
  clm::cli::add_scope(app);
  clm::cli::add_margins(app);
  return clm::run_command_line(app, argc, argv);
}
