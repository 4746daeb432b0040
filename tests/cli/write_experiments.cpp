// The CTest fixture cli_experiments: runs the commissioning experiments of
// the default motor once per build tree and writes the files cli_tests read
// (cli_support.hpp, ExperimentFiles), instead of once per test process.
//
//   cli_experiments DIRECTORY
#include <exception>
#include <iostream>

#include "cli/cli_support.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: cli_experiments DIRECTORY\n";
    return 2;
  }
  try {
    clm::cli_test::write_experiment_files(argv[1]);
  } catch (const std::exception& error) {
    std::cerr << "cli_experiments: " << error.what() << "\n";
    return 1;
  }
  std::cout << "cli_experiments: written to " << argv[1] << "\n";
  return 0;
}
