#include "commutation/identification/excitation.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace clm::identification {

RegressorQuality regressor_quality(const Eigen::MatrixXd& data_gram, const std::vector<ColumnGroup>& groups) {
  const Eigen::Index p = data_gram.rows();
  if (data_gram.cols() != p) throw std::invalid_argument("regressor_quality: the normal matrix is not square");
  const Eigen::VectorXd diagonal = data_gram.diagonal();
  const double largest = p > 0 ? diagonal.maxCoeff() : 0.0;
  std::vector<bool> excited(static_cast<std::size_t>(p), false);
  int unexcited = 0;
  Eigen::Index covered = 0;
  for (const ColumnGroup& group : groups) {
    if (group.first < 0 || group.count < 1 || group.first + group.count > p) {
      throw std::invalid_argument("regressor_quality: a column group outside the normal matrix");
    }
    covered += group.count;
    std::vector<double> values(diagonal.data() + group.first, diagonal.data() + group.first + group.count);
    std::nth_element(values.begin(), values.begin() + group.count / 2, values.end());
    const double median = values[static_cast<std::size_t>(group.count / 2)];
    for (int k = group.first; k < group.first + group.count; ++k) {
      const double d = diagonal[k];
      const bool excited_k = d > 1e-12 * largest && (group.count < 3 || d >= kUnexcitedShare * median);
      excited[static_cast<std::size_t>(k)] = excited_k;
      if (!excited_k && group.counted) ++unexcited;
    }
  }
  if (covered != p) throw std::invalid_argument("regressor_quality: the column groups do not cover every column once");
  RegressorQuality quality;
  quality.parameters = static_cast<int>(p);
  std::vector<Eigen::Index> kept;
  for (Eigen::Index k = 0; k < p; ++k) {
    if (excited[static_cast<std::size_t>(k)]) kept.push_back(k);
  }
  quality.unexcited = unexcited;
  if (kept.empty()) return quality;
  const auto n = static_cast<Eigen::Index>(kept.size());
  Eigen::MatrixXd scaled(n, n);
  for (Eigen::Index r = 0; r < n; ++r) {
    for (Eigen::Index c = 0; c < n; ++c) {
      scaled(r, c) = data_gram(kept[r], kept[c]) / std::sqrt(diagonal[kept[r]] * diagonal[kept[c]]);
    }
  }
  const Eigen::VectorXd eigenvalues = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(scaled, Eigen::EigenvaluesOnly).eigenvalues();
  const double high = eigenvalues.maxCoeff();
  const double floor = high / (kMaxRegressorCondition * kMaxRegressorCondition);
  double low = high;
  for (const double value : eigenvalues) {
    if (value < floor) {
      ++quality.dependent;
    } else {
      low = std::min(low, value);
    }
  }
  quality.condition = std::sqrt(high / low);
  return quality;
}

std::vector<ExcitationGap> excitation_gaps(const CoilSetDataset& data, double pole_pitch_m) {
  std::vector<ExcitationGap> gaps;
  const Eigen::Index samples = data.size();
  if (samples == 0 || !(pole_pitch_m > 0.0)) return gaps;
  const double low = data.position_m.minCoeff();
  const double width = pole_pitch_m / 8.0;
  const int bins = std::max(1, static_cast<int>(std::ceil((data.position_m.maxCoeff() - low) / width)));
  Eigen::VectorXd count = Eigen::VectorXd::Zero(bins);
  Eigen::MatrixXd square_sum = Eigen::MatrixXd::Zero(2, bins);
  for (Eigen::Index t = 0; t < samples; ++t) {
    const int bin = std::clamp(static_cast<int>((data.position_m[t] - low) / width), 0, bins - 1);
    count[bin] += 1.0;
    square_sum.col(bin) += data.currents_A.col(t).cwiseAbs2();
  }
  const double mean_count = static_cast<double>(samples) / bins;
  const Eigen::Vector2d rms_A = (data.currents_A.rowwise().squaredNorm() / static_cast<double>(samples)).cwiseSqrt();
  const auto lack_of = [&](int bin, ExcitationLack lack) {
    if (lack == ExcitationLack::kNoSamples) return count[bin] < kSparseShare * mean_count;
    if (count[bin] < kSparseShare * mean_count) return false;  // reported as no samples
    const int coil = lack == ExcitationLack::kNoCurrentA ? 0 : 1;
    return std::sqrt(square_sum(coil, bin) / count[bin]) < kSparseShare * rms_A[coil];
  };
  for (const ExcitationLack lack : {ExcitationLack::kNoSamples, ExcitationLack::kNoCurrentA, ExcitationLack::kNoCurrentB}) {
    int previous = -2;  // the last bin with this lack
    for (int bin = 0; bin < bins; ++bin) {
      if (!lack_of(bin, lack)) continue;
      if (bin == previous + 1) {
        gaps.back().high_m = low + (bin + 1) * width;
      } else {
        gaps.push_back({low + bin * width, low + (bin + 1) * width, lack});
      }
      previous = bin;
    }
  }
  std::stable_sort(gaps.begin(), gaps.end(), [](const ExcitationGap& a, const ExcitationGap& b) { return a.low_m < b.low_m; });
  return gaps;
}

const char* describe(ExcitationLack lack) {
  switch (lack) {
    case ExcitationLack::kNoSamples: return "no samples";
    case ExcitationLack::kNoCurrentA: return "no current of coil a";
    case ExcitationLack::kNoCurrentB: return "no current of coil b";
  }
  return "?";
}

std::vector<std::string> identification_warnings(const RegressorQuality& regressors,
                                                 const std::vector<ExcitationGap>& gaps) {
  std::vector<std::string> warnings;
  char text[256];
  if (regressors.unexcited > 0) {
    std::snprintf(text, sizeof text,
                  "%d of %d linear parameters are not excited by the data: the smoothness penalty and the "
                  "regularisation set them, not the measurement",
                  regressors.unexcited, regressors.parameters);
    warnings.emplace_back(text);
  }
  for (const ExcitationGap& gap : gaps) {
    std::snprintf(text, sizeof text, "%s in [%.4g, %.4g] m: the model there is %s", describe(gap.lack), gap.low_m,
                  gap.high_m,
                  gap.lack == ExcitationLack::kNoSamples ? "interpolated, not measured"
                                                         : "not measured for that coil's gain");
    warnings.emplace_back(text);
  }
  return warnings;
}

}  // namespace clm::identification
