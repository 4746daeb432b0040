#include "commutation/identification/dataset.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace clm::identification {

void check_dataset(const CoilSetDataset& data, const char* what) {
  if (data.size() < 10) throw std::invalid_argument(std::string(what) + " data has fewer than 10 samples");
  if (data.currents_A.cols() != data.size() || data.wrench.cols() != data.size() ||
      static_cast<Eigen::Index>(data.group.size()) != data.size() ||
      (data.velocity_m_per_s.size() != 0 && data.velocity_m_per_s.size() != data.size())) {
    throw std::invalid_argument(std::string(what) + " data columns have different lengths");
  }
}

CoilSetDataset CoilSetDataset::subset(const std::vector<Eigen::Index>& indices) const {
  CoilSetDataset out;
  const auto n = static_cast<Eigen::Index>(indices.size());
  out.position_m.resize(n);
  out.currents_A.resize(2, n);
  out.wrench.resize(3, n);
  out.group.resize(indices.size());
  const bool velocity = velocity_m_per_s.size() == position_m.size() && position_m.size() > 0;
  if (velocity) out.velocity_m_per_s.resize(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Index i = indices[static_cast<std::size_t>(k)];
    out.position_m[k] = position_m[i];
    if (velocity) out.velocity_m_per_s[k] = velocity_m_per_s[i];
    out.currents_A.col(k) = currents_A.col(i);
    out.wrench.col(k) = wrench.col(i);
    out.group[static_cast<std::size_t>(k)] = group[static_cast<std::size_t>(i)];
  }
  return out;
}

CoilSetDataset joined(const CoilSetDataset& first, const CoilSetDataset& second) {
  CoilSetDataset out;
  const Eigen::Index n = first.size() + second.size();
  out.position_m.resize(n);
  out.position_m << first.position_m, second.position_m;
  out.currents_A.resize(2, n);
  out.currents_A << first.currents_A, second.currents_A;
  out.wrench.resize(3, n);
  out.wrench << first.wrench, second.wrench;
  // Velocities only when both have them; a join without them has none.
  if (first.velocity_m_per_s.size() == first.size() && second.velocity_m_per_s.size() == second.size() &&
      n > 0) {
    out.velocity_m_per_s.resize(n);
    out.velocity_m_per_s << first.velocity_m_per_s, second.velocity_m_per_s;
  }
  out.group = first.group;
  out.group.insert(out.group.end(), second.group.begin(), second.group.end());
  return out;
}

DataSplit split_contiguous_blocks(const CoilSetDataset& data, double validation_fraction, int blocks_per_group) {
  if (!(validation_fraction >= 0.0 && validation_fraction < 1.0)) {
    throw std::invalid_argument("validation fraction must lie in [0, 1), got " + std::to_string(validation_fraction));
  }
  if (blocks_per_group < 1) throw std::invalid_argument("blocks_per_group must be at least 1");
  const int held_out = static_cast<int>(std::lround(validation_fraction * blocks_per_group));
  std::vector<bool> is_validation_block(static_cast<std::size_t>(blocks_per_group), false);
  for (int k = 0; k < held_out; ++k) {
    const int block = static_cast<int>((k + 0.5) * blocks_per_group / held_out);
    is_validation_block[static_cast<std::size_t>(std::min(block, blocks_per_group - 1))] = true;
  }
  DataSplit split;
  for (int g = 0; g < 2; ++g) {
    std::vector<Eigen::Index> members;
    for (Eigen::Index i = 0; i < data.size(); ++i) {
      if (data.group[static_cast<std::size_t>(i)] == g) members.push_back(i);
    }
    const auto count = static_cast<double>(members.size());
    std::size_t previous_block = is_validation_block.size();  // none yet in this group
    for (std::size_t k = 0; k < members.size(); ++k) {
      const auto block = static_cast<std::size_t>(std::min<double>(blocks_per_group - 1, std::floor(k * blocks_per_group / count)));
      if (!is_validation_block[block]) {
        split.training.push_back(members[k]);
        continue;
      }
      split.validation.push_back(members[k]);
      if (block != previous_block) split.validation_blocks.push_back(0);
      ++split.validation_blocks.back();
      previous_block = block;
    }
  }
  return split;
}

}  // namespace clm::identification
