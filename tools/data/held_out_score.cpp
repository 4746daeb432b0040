#include "tools/data/held_out_score.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace clm::data {

std::vector<double> block_sums(const Eigen::VectorXd& squared_errors, const std::vector<std::size_t>& block_samples) {
  std::vector<double> sums;
  sums.reserve(block_samples.size());
  Eigen::Index at = 0;
  for (const std::size_t samples : block_samples) {
    const auto n = static_cast<Eigen::Index>(samples);
    if (at + n > squared_errors.size()) break;
    sums.push_back(squared_errors.segment(at, n).sum());
    at += n;
  }
  if (sums.size() != block_samples.size() || at != squared_errors.size()) {
    throw std::invalid_argument("held-out blocks of " + std::to_string(at) + " samples in all for " +
                                std::to_string(squared_errors.size()) + " held-out squared errors");
  }
  return sums;
}

std::vector<HeldOutBlock> held_out_blocks(const Eigen::VectorXd& model_N2, const Eigen::VectorXd& physics_N2,
                                          const std::vector<std::size_t>& block_samples) {
  if (model_N2.size() != physics_N2.size()) {
    throw std::invalid_argument("held-out errors: " + std::to_string(model_N2.size()) + " of the model, " +
                                std::to_string(physics_N2.size()) + " of the physics-only fit");
  }
  const std::vector<double> model = block_sums(model_N2, block_samples);
  const std::vector<double> physics = block_sums(physics_N2, block_samples);
  std::vector<HeldOutBlock> blocks(model.size());
  for (std::size_t b = 0; b < blocks.size(); ++b) blocks[b] = {model[b], physics[b]};
  return blocks;
}

namespace {

// One coil set's ratio R_l and the linearised per-block terms z_lb of the
// score (held_out_score); false when its physics error is not positive.
bool linearised(const std::vector<HeldOutBlock>& blocks, double& ratio, std::vector<double>& z) {
  double model = 0.0, physics = 0.0;
  for (const auto& block : blocks) {
    model += block.model_N2;
    physics += block.physics_N2;
  }
  z.clear();
  if (!(physics > 0.0)) return false;
  ratio = model / physics;
  for (const auto& block : blocks) z.push_back((block.model_N2 - ratio * block.physics_N2) / physics);
  return true;
}

// Σ_l B_l/(B_l−1) Σ_b d_lb² over the coil sets' per-block terms; NaN when a
// coil set has fewer than two blocks.
double variance_of_sum(const std::vector<std::vector<double>>& terms) {
  double variance = 0.0;
  for (const auto& coil_set : terms) {
    const auto blocks = static_cast<double>(coil_set.size());
    if (coil_set.size() < 2) return std::numeric_limits<double>::quiet_NaN();
    double square = 0.0;
    for (const double d : coil_set) square += d * d;
    variance += blocks / (blocks - 1.0) * square;
  }
  return variance;
}

bool same_shape(const HeldOutBlocks& a, const HeldOutBlocks& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t l = 0; l < a.size(); ++l) {
    if (a[l].size() != b[l].size()) return false;
  }
  return true;
}

}  // namespace

ScoreEstimate held_out_score(const HeldOutBlocks& blocks) {
  ScoreEstimate estimate;
  if (blocks.empty()) return estimate;
  std::vector<std::vector<double>> terms;
  double score = 0.0;
  for (const auto& coil_set : blocks) {
    double ratio = 0.0;
    std::vector<double> z;
    if (!linearised(coil_set, ratio, z)) continue;
    score += ratio;
    terms.push_back(std::move(z));
  }
  estimate.value = score;
  estimate.standard_error = std::sqrt(variance_of_sum(terms));
  return estimate;
}

ScoreEstimate paired_difference(const HeldOutBlocks& a, const HeldOutBlocks& b) {
  if (!same_shape(a, b)) {
    throw std::invalid_argument("paired difference: the two laws' held-out blocks differ in coil sets or blocks");
  }
  ScoreEstimate estimate;
  if (a.empty()) return estimate;
  std::vector<std::vector<double>> terms;
  double difference = 0.0;
  for (std::size_t l = 0; l < a.size(); ++l) {
    double ratio_a = 0.0, ratio_b = 0.0;
    std::vector<double> z_a, z_b;
    const bool has_a = linearised(a[l], ratio_a, z_a);
    const bool has_b = linearised(b[l], ratio_b, z_b);
    // A coil set one score leaves out counts as 0 in it, as in held_out_score.
    if (!has_a) z_a.assign(a[l].size(), 0.0);
    if (!has_b) z_b.assign(b[l].size(), 0.0);
    if (!has_a && !has_b) continue;
    difference += (has_a ? ratio_a : 0.0) - (has_b ? ratio_b : 0.0);
    std::vector<double> d(z_a.size());
    for (std::size_t k = 0; k < d.size(); ++k) d[k] = z_a[k] - z_b[k];
    terms.push_back(std::move(d));
  }
  estimate.value = difference;
  estimate.standard_error = std::sqrt(variance_of_sum(terms));
  return estimate;
}

HeldOutBlocks physics_only(const HeldOutBlocks& any_law) {
  HeldOutBlocks physics = any_law;
  for (auto& coil_set : physics) {
    for (auto& block : coil_set) block.model_N2 = block.physics_N2;
  }
  return physics;
}

LawScore law_score(std::string law, HeldOutBlocks blocks) {
  LawScore score{std::move(law), std::move(blocks), {}};
  score.score = held_out_score(score.blocks);
  return score;
}

ScoreEstimate score_difference(const LawScore& a, const LawScore& b) {
  if (!a.blocks.empty() && same_shape(a.blocks, b.blocks)) return paired_difference(a.blocks, b.blocks);
  return {a.score.value - b.score.value, std::hypot(a.score.standard_error, b.score.standard_error)};
}

Verdict choose_law(const std::vector<LawScore>& laws, double k) {
  if (laws.empty()) throw std::invalid_argument("choose_law: no laws to choose from");
  for (const auto& law : laws) {
    if (std::isnan(law.score.value)) throw std::invalid_argument("choose_law: the score of " + law.law + " is NaN");
  }
  std::size_t lowest = 0;
  for (std::size_t j = 1; j < laws.size(); ++j) {
    if (laws[j].score.value < laws[lowest].score.value) lowest = j;
  }
  Verdict verdict;
  std::vector<std::size_t> tied;
  for (std::size_t j = 0; j < laws.size(); ++j) {
    const ScoreEstimate d = j == lowest ? ScoreEstimate{0.0, 0.0} : score_difference(laws[j], laws[lowest]);
    // Without a standard error only an equal score ties.
    if (d.value <= 0.0 || d.value < k * d.standard_error) tied.push_back(j);
  }
  const std::size_t chosen = tied.front();  // the first in the order of preference
  verdict.recommended = laws[chosen].law;
  verdict.tie = tied.size() > 1;
  if (verdict.tie) {
    for (const std::size_t j : tied) verdict.tied.push_back(laws[j].law);
  }
  std::size_t runner_up = laws.size();
  if (chosen != lowest) {
    runner_up = lowest;
  } else {
    for (std::size_t j = 0; j < laws.size(); ++j) {
      if (j != chosen && (runner_up == laws.size() || laws[j].score.value < laws[runner_up].score.value)) runner_up = j;
    }
  }
  if (runner_up < laws.size()) {
    verdict.runner_up = laws[runner_up].law;
    const ScoreEstimate margin = score_difference(laws[runner_up], laws[chosen]);
    verdict.margin_score = margin.value;
    verdict.margin_standard_errors =
        margin.standard_error > 0.0 ? margin.value / margin.standard_error
        : margin.standard_error == 0.0 && margin.value != 0.0 ? std::copysign(std::numeric_limits<double>::infinity(), margin.value)
                                                               : std::numeric_limits<double>::quiet_NaN();
  }
  return verdict;
}

}  // namespace clm::data
