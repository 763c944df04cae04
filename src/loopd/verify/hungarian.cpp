#include "loopd/verify/hungarian.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace loopd {

Assignment hungarian_assign(const Eigen::MatrixXd& cost_in) {
  Assignment out;
  const int rows = static_cast<int>(cost_in.rows()), cols = static_cast<int>(cost_in.cols());
  out.row_to_col.assign(static_cast<std::size_t>(rows), -1);
  out.col_to_row.assign(static_cast<std::size_t>(cols), -1);
  if (rows == 0 || cols == 0) return out;

  // Replace non-finite entries by a "forbidden" cost above every finite one, so they lose against any finite choice.
  double lo = 0.0, hi = 0.0;
  bool any_finite = false;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      if (std::isfinite(cost_in(r, c))) {
        lo = any_finite ? std::min(lo, cost_in(r, c)) : cost_in(r, c);
        hi = any_finite ? std::max(hi, cost_in(r, c)) : cost_in(r, c);
        any_finite = true;
      }
  const double forbidden = any_finite ? hi + (hi - lo + 1.0) * static_cast<double>(std::min(rows, cols) + 1) : 1.0;
  // Work on the orientation with n <= m (rows are assigned completely).
  const bool transposed = rows > cols;
  const int n = transposed ? cols : rows, m = transposed ? rows : cols;
  auto a = [&](int i, int j) {  // 1-based, i <= n, j <= m
    const double v = transposed ? cost_in(j - 1, i - 1) : cost_in(i - 1, j - 1);
    return std::isfinite(v) ? v : forbidden;
  };

  // Shortest augmenting paths with row/column potentials u, v (Kuhn 1955, Munkres 1957; Jonker-Volgenant form).
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> u(static_cast<std::size_t>(n) + 1, 0.0), v(static_cast<std::size_t>(m) + 1, 0.0), minv(static_cast<std::size_t>(m) + 1);
  std::vector<int> p(static_cast<std::size_t>(m) + 1, 0), way(static_cast<std::size_t>(m) + 1, 0);
  std::vector<char> used(static_cast<std::size_t>(m) + 1);
  for (int i = 1; i <= n; ++i) {
    p[0] = i;
    int j0 = 0;
    std::fill(minv.begin(), minv.end(), inf);
    std::fill(used.begin(), used.end(), 0);
    do {
      used[static_cast<std::size_t>(j0)] = 1;
      const int i0 = p[static_cast<std::size_t>(j0)];
      double delta = inf;
      int j1 = 0;
      for (int j = 1; j <= m; ++j) {
        const auto sj = static_cast<std::size_t>(j);
        if (used[sj]) continue;
        const double cur = a(i0, j) - u[static_cast<std::size_t>(i0)] - v[sj];
        if (cur < minv[sj]) {
          minv[sj] = cur;
          way[sj] = j0;
        }
        if (minv[sj] < delta) {
          delta = minv[sj];
          j1 = j;
        }
      }
      for (int j = 0; j <= m; ++j) {
        const auto sj = static_cast<std::size_t>(j);
        if (used[sj]) {
          u[static_cast<std::size_t>(p[sj])] += delta;
          v[sj] -= delta;
        } else {
          minv[sj] -= delta;
        }
      }
      j0 = j1;
    } while (p[static_cast<std::size_t>(j0)] != 0);
    do {
      const int j1 = way[static_cast<std::size_t>(j0)];
      p[static_cast<std::size_t>(j0)] = p[static_cast<std::size_t>(j1)];
      j0 = j1;
    } while (j0 != 0);
  }

  for (int j = 1; j <= m; ++j) {
    const int i = p[static_cast<std::size_t>(j)];
    if (i == 0) continue;
    const int r = transposed ? j - 1 : i - 1;
    const int c = transposed ? i - 1 : j - 1;
    out.row_to_col[static_cast<std::size_t>(r)] = c;
    out.col_to_row[static_cast<std::size_t>(c)] = r;
    out.total_cost += a(i, j);
  }
  return out;
}

}  // namespace loopd
