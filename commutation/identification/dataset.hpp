#pragma once
// Identification data of one coil set (data sets Z_1^l, Z_2^l of eq. 13): the
// coil set driven alone with two phase offsets; currents either measured or
// reconstructed through the drive's fixed commutation (Fig. 6).

#include <Eigen/Core>
#include <cstddef>
#include <vector>

namespace clm::identification {

struct CoilSetDataset {
  Eigen::VectorXd position_m;              ///< y(t), N samples
  /// dy/dt from the data's positions and times (velocity_from_positions), N
  /// samples; empty when the data have no times. The direction-dependent
  /// force of Remark 5.1 is identified against it (docs/commutation.md,
  /// "Nuisance terms").
  Eigen::VectorXd velocity_m_per_s;
  Eigen::Matrix<double, 2, Eigen::Dynamic> currents_A;  ///< [i_a; i_b] per sample
  Eigen::Matrix<double, 3, Eigen::Dynamic> wrench;      ///< measured [F_y N; F_x N; T_z N·m]
  std::vector<int> group;                  ///< 0 or 1: which offset experiment a sample belongs to

  Eigen::Index size() const { return position_m.size(); }
  /// The samples whose index is listed, in that order.
  CoilSetDataset subset(const std::vector<Eigen::Index>& indices) const;
};

/// The samples of `first`, then those of `second`.
CoilSetDataset joined(const CoilSetDataset& first, const CoilSetDataset& second);

/// Throws std::invalid_argument "<what> data has fewer than 10 samples" or
/// "<what> data columns have different lengths"; the check every fit makes first.
void check_dataset(const CoilSetDataset& data, const char* what);

/// Training and validation indices: each group is cut into `blocks_per_group`
/// contiguous blocks and round(fraction·blocks) of them, spread evenly, are
/// held out. fraction = 0 puts everything into training.
struct DataSplit {
  std::vector<Eigen::Index> training;
  std::vector<Eigen::Index> validation;
  /// How many consecutive entries of `validation` each held-out block holds,
  /// in order (group 0's blocks, then group 1's); empty blocks are left out.
  /// The held-out error's uncertainty is estimated from these blocks.
  std::vector<std::size_t> validation_blocks;
};
DataSplit split_contiguous_blocks(const CoilSetDataset& data, double validation_fraction, int blocks_per_group = 10);

/// Mean over samples of the squared force error per direction [y, x, z]
/// (the data term of eq. 26, direction by direction).
using DirectionCost = Eigen::Vector3d;

}  // namespace clm::identification
