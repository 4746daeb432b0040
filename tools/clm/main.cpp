// clm: the command-line tool of clm-servo. Subcommands are added by the
// components they belong to; each has --help.

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>

#include "clm_version.hpp"

int main(int argc, char** argv) {
  CLI::App app{"clm: commissioning and commutation tools for coreless linear motors"};
  app.set_version_flag("--version", std::string("clm ") + CLM_SERVO_VERSION);
  app.require_subcommand(0, 1);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (app.get_subcommands().empty()) {
    std::cout << app.help();
    return 0;
  }
  return 0;
}
