// The recommendation of `clm commission` from constructed held-out blocks:
// a tie is reported as one and broken by the order of preference, a clear
// win goes to the lowest score, and report.json and report.md carry the
// verdict (docs/commutation.md, "The recommendation").
#include <catch2/catch.hpp>

#include <string>

#include "tools/commission/commission.hpp"

using namespace clm;

namespace {

// Two coil sets of four blocks, physics-only error 2 N² per block; the
// model's per block.
data::HeldOutBlocks blocks(const std::vector<double>& first, const std::vector<double>& second) {
  data::HeldOutBlocks out(2);
  for (const double m : first) out[0].push_back({m, 2.0});
  for (const double m : second) out[1].push_back({m, 2.0});
  return out;
}

data::IdentifySummary selection(const std::string& capacity, const data::HeldOutBlocks& held_out) {
  data::IdentifySummary summary;
  data::CapacityTrial trial;
  trial.capacity = capacity;
  trial.held_out = held_out;
  trial.validation_score = data::held_out_score(held_out).value;
  summary.trials.push_back(trial);
  return summary;
}

commission::Report report_with(const data::HeldOutBlocks& spline, const data::HeldOutBlocks& position,
                               const data::HeldOutBlocks& pgnn) {
  commission::Report report;
  report.coil_sets = 2;
  report.spline_selection = selection("spline knots 3.75 mm", spline);
  report.pgnn_selection = selection("pgnn 16/32", pgnn);
  report.from_position = true;
  report.position_mass_source = "the force sensor's mechanics fit";
  report.position_held_out = position;
  report.position_validation_score = data::held_out_score(position).value;
  return report;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST_CASE("the recommendation reports a tie and breaks it by the order of preference", "[commission]") {
  // The spline from positions scores lowest by far less than the blocks'
  // spread of its difference with the spline: a tie; the spline comes first.
  auto report = report_with(blocks({0.40, 0.20, 0.30, 0.26}, {0.24, 0.30, 0.22, 0.28}),
                            blocks({0.36, 0.24, 0.27, 0.27}, {0.22, 0.33, 0.20, 0.29}),
                            blocks({1.0, 0.9, 1.1, 1.0}, {1.0, 0.9, 1.1, 1.0}));
  commission::recommend(report);
  CHECK(report.recommended == "spline");
  CHECK(report.verdict.tie);
  CHECK(report.decided_by == "tie rule");
  CHECK(report.verdict.runner_up == "spline-position");
  CHECK(report.verdict.margin_score < 0.0);
  CHECK(report.verdict.margin_standard_errors > -data::kTieStandardErrors);
  CHECK(report.force_recommended == "spline");
  CHECK(contains(report.recommendation, "a tie, broken by the order of preference"));
  // Every law with its score and standard error, classical (physics-only) first.
  REQUIRE(report.law_scores.size() == 4);
  CHECK(report.law_scores[0].law == "classical");
  CHECK(report.law_scores[0].score.value == 2.0);
  const std::string json = commission::report_json(report);
  CHECK(contains(json, "\"verdict\": {\"recommended\": \"spline\", \"decided_by\": \"tie rule\", \"tie\": true"));
  CHECK(contains(json, "\"runner_up\": \"spline-position\""));
  CHECK(contains(json, "\"spline-position\": {\"score\": "));
  CHECK(contains(json, "\"standard_error\": "));
  const std::string markdown = commission::report_markdown(report);
  CHECK(contains(markdown, "## Verdict"));
  CHECK(contains(markdown, "law for service: **spline**, by the tie rule"));
  CHECK(contains(markdown, "| spline-position | "));
}

TEST_CASE("a clear win is recommended although it is last in the order of preference", "[commission]") {
  // The PGNN below both splines in every block, by far more than the spread.
  auto report = report_with(blocks({0.40, 0.20, 0.30, 0.26}, {0.24, 0.30, 0.22, 0.28}),
                            blocks({0.42, 0.22, 0.31, 0.27}, {0.25, 0.31, 0.24, 0.29}),
                            blocks({0.10, 0.05, 0.08, 0.07}, {0.06, 0.08, 0.05, 0.07}));
  commission::recommend(report);
  CHECK(report.recommended == "pgnn");
  CHECK_FALSE(report.verdict.tie);
  CHECK(report.decided_by == "validation score");
  CHECK(report.verdict.runner_up == "spline");
  CHECK(report.verdict.margin_standard_errors > data::kTieStandardErrors);
  CHECK(report.force_recommended == "pgnn");
  CHECK(contains(report.recommendation, "a clear win"));
  CHECK(contains(commission::report_json(report), "\"tie\": false"));
  CHECK(contains(commission::report_markdown(report), "law for service: **pgnn**, a clear win"));
}

TEST_CASE("models within the noise of the physics-only fit leave the calibrated classical law", "[commission]") {
  // Scores near 2 (the physics-only fit's, one per coil set) with a wide spread.
  auto report = report_with(blocks({1.6, 2.4, 1.2, 2.2}, {2.4, 1.4, 2.2, 1.8}),
                            blocks({2.6, 2.4, 2.2, 2.2}, {2.4, 2.4, 2.2, 2.8}),
                            blocks({2.0, 2.8, 1.6, 2.4}, {2.6, 1.6, 2.4, 2.0}));
  commission::recommend(report);
  CHECK(report.recommended == "classical");
  CHECK(report.force_recommended == "classical");
  INFO(report.recommendation);
  CHECK(contains(report.recommendation, "keep the calibrated classical law"));
}

TEST_CASE("report.json's ratios are well formed whichever laws were evaluated", "[commission]") {
  // Each member of "ratios" is written only when its laws were evaluated; the
  // separators between them follow what was written, not what might have been.
  const auto result = [](const std::string& name, double mse, double tracking_m2) {
    commission::CommutationResult r;
    r.name = name;
    r.evaluated = true;
    r.mse.filtered = {mse, mse, mse};
    r.tracking_mse_m2 = tracking_m2;
    return r;
  };
  for (const std::vector<std::string>& laws : std::vector<std::vector<std::string>>{
           {"classical", "spline"}, {"classical", "oracle"}, {"spline", "oracle"}, {"classical"}, {}}) {
    commission::Report report;
    report.coil_sets = 2;
    for (const auto& law : laws) report.results.push_back(result(law, 4.0, 1e-10));
    const std::string json = commission::report_json(report);
    const auto begin = json.find("\"ratios\": {");
    REQUIRE(begin != std::string::npos);
    const std::string ratios = json.substr(begin, json.find('\n', begin) - begin);
    INFO("laws evaluated: " << laws.size() << ", ratios line: " << ratios);
    CHECK_FALSE(contains(ratios, "{, "));
    CHECK_FALSE(contains(ratios, ", ,"));
    CHECK_FALSE(contains(ratios, ", }"));
  }
}

TEST_CASE("a law clm-servod would refuse does not compete, and the report says why", "[commission]") {
  // The PGNN would win clearly, but its gains beyond its data are no motor's.
  auto report = report_with(blocks({0.40, 0.20, 0.30, 0.26}, {0.24, 0.30, 0.22, 0.28}),
                            blocks({0.42, 0.22, 0.31, 0.27}, {0.25, 0.31, 0.24, 0.29}),
                            blocks({0.10, 0.05, 0.08, 0.07}, {0.06, 0.08, 0.05, 0.07}));
  report.refused_laws["pgnn"] = "coil set 2 at y = -0.1 m: motor constant 962 N/A outside [6.7, 670] N/A";
  commission::recommend(report);
  CHECK(report.recommended == "spline");
  CHECK(report.force_recommended == "spline");
  for (const auto& law : report.law_scores) CHECK(law.law != "pgnn");
  CHECK(contains(report.recommendation, "pgnn not a candidate, clm-servod refuses it: coil set 2 at y = -0.1 m"));
}
