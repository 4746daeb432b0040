// An output directory of `clm commission` says whether the run finished:
// INCOMPLETE from its creation until the report is written.
#include <catch2/catch.hpp>

#include <filesystem>

#include "support/temporary_directory.hpp"
#include "tools/commission/commission.hpp"

using namespace clm;

TEST_CASE("a run stopped early leaves its directory marked incomplete and writes no report", "[commission]") {
  const test::TemporaryDirectory directory("clm-commission-stopped");
  commission::Options options;
  options.config_path = std::string(CLM_SOURCE_DIR) + "/config/servod.yaml";
  options.out_dir = directory.file("commission");
  options.program_path = std::string(CLM_SOURCE_DIR) + "/tests/support/one_stroke_program.yaml";
  options.experiment_program_path = options.program_path;
  options.validation_program_path = "none";
  // Stopped as Ctrl-C would stop it: after the first experiment run.
  struct Stopped {};
  CHECK_THROWS_AS(commission::run(options,
                                  [](const commission::Progress& p) {
                                    if (p.step == "experiments" && p.fraction > 0.0) throw Stopped{};
                                  }),
                  Stopped);
  CHECK(std::filesystem::is_regular_file(options.out_dir + "/" + commission::kIncompleteMarker));
  CHECK_FALSE(std::filesystem::exists(options.out_dir + "/report.json"));
  CHECK_FALSE(std::filesystem::exists(options.out_dir + "/report.md"));
}
