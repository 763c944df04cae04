#pragma once
/// @file Optimal assignment (Hungarian / Kuhn-Munkres with potentials, O(n^2 m)) used to match segment centroids of
/// two aligned scans (Vlaminck 2019, Sec. 4.3).
#include <Eigen/Core>
#include <vector>

namespace loopd {

/// @brief Result of hungarian_assign.
struct Assignment {
  std::vector<int> row_to_col;  ///< column assigned to each row, -1 when the row is left out (more rows than columns)
  std::vector<int> col_to_row;  ///< row assigned to each column, -1 when the column is left out
  double total_cost = 0;        ///< sum of the assigned costs (after the non-finite replacement below)
};

/// @brief Minimum-cost assignment on a rectangular n x m cost matrix: min(n, m) pairs, each row and column used at
/// most once, minimising the sum of costs. O(min^2 * max).
/// @note Non-finite entries (NaN, +-inf) are treated as a cost larger than every finite entry ("forbidden"); they are
/// only chosen when unavoidable. An empty matrix gives an empty assignment.
Assignment hungarian_assign(const Eigen::MatrixXd& cost);

}  // namespace loopd
