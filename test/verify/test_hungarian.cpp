#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "loopd/verify/hungarian.hpp"

using namespace loopd;

namespace {
/// Brute force: minimum over all injections of the smaller side into the larger one.
double brute_force_min(const Eigen::MatrixXd& c) {
  const bool t = c.rows() > c.cols();
  const Eigen::MatrixXd a = t ? Eigen::MatrixXd(c.transpose()) : c;
  const int n = static_cast<int>(a.rows()), m = static_cast<int>(a.cols());
  std::vector<int> cols(static_cast<std::size_t>(m));
  for (int j = 0; j < m; ++j) cols[static_cast<std::size_t>(j)] = j;
  double best = std::numeric_limits<double>::infinity();
  // Every permutation of the columns; its first n entries give an injection (duplicates are harmless).
  do {
    double s = 0.0;
    for (int i = 0; i < n; ++i) s += a(i, cols[static_cast<std::size_t>(i)]);
    best = std::min(best, s);
  } while (std::next_permutation(cols.begin(), cols.end()));
  return best;
}

void check_valid(const Eigen::MatrixXd& c, const Assignment& a) {
  const int n = static_cast<int>(c.rows()), m = static_cast<int>(c.cols());
  REQUIRE(a.row_to_col.size() == static_cast<std::size_t>(n));
  REQUIRE(a.col_to_row.size() == static_cast<std::size_t>(m));
  int assigned = 0;
  double sum = 0.0;
  std::vector<int> seen(static_cast<std::size_t>(m), 0);
  for (int i = 0; i < n; ++i) {
    const int j = a.row_to_col[static_cast<std::size_t>(i)];
    if (j < 0) continue;
    REQUIRE(j < m);
    REQUIRE(a.col_to_row[static_cast<std::size_t>(j)] == i);
    REQUIRE(seen[static_cast<std::size_t>(j)]++ == 0);
    ++assigned;
    sum += c(i, j);
  }
  CHECK(assigned == std::min(n, m));
  CHECK(a.total_cost == Approx(sum).margin(1e-9));
}
}  // namespace

TEST_CASE("Hungarian equals brute force on all shapes up to 7 x 7 (random real and tied integer costs)") {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> real(0.0, 10.0);
  std::uniform_int_distribution<int> small_int(0, 3);  // many ties
  int cases = 0;
  for (int n = 1; n <= 7; ++n)
    for (int m = 1; m <= 7; ++m)
      for (int trial = 0; trial < 12; ++trial) {
        Eigen::MatrixXd c(n, m);
        for (int i = 0; i < n; ++i)
          for (int j = 0; j < m; ++j) c(i, j) = trial % 2 == 0 ? real(rng) : static_cast<double>(small_int(rng));
        const Assignment a = hungarian_assign(c);
        INFO(n << "x" << m << " trial " << trial << "\n" << c);
        check_valid(c, a);
        CHECK(a.total_cost == Approx(brute_force_min(c)).margin(1e-9));
        ++cases;
      }
  CHECK(cases == 7 * 7 * 12);
}

TEST_CASE("Hungarian handles negative costs") {
  Eigen::MatrixXd c(3, 3);
  c << -1, -5, 0, -3, 2, -2, 4, -1, -6;
  const Assignment a = hungarian_assign(c);
  check_valid(c, a);
  CHECK(a.total_cost == Approx(brute_force_min(c)));
}

TEST_CASE("Hungarian: empty matrices and non-finite entries") {
  CHECK(hungarian_assign(Eigen::MatrixXd(0, 0)).row_to_col.empty());
  const Assignment e = hungarian_assign(Eigen::MatrixXd(0, 4));
  CHECK(e.col_to_row == std::vector<int>(4, -1));
  const Assignment e2 = hungarian_assign(Eigen::MatrixXd(3, 0));
  CHECK(e2.row_to_col == std::vector<int>(3, -1));

  const double inf = std::numeric_limits<double>::infinity();
  Eigen::MatrixXd c(3, 3);
  c << inf, 1, NAN, 2, inf, 5, 1, 7, inf;
  const Assignment a = hungarian_assign(c);
  // The only all-finite assignment: (0,1), (1,2), (2,0).
  CHECK(a.row_to_col == std::vector<int>{1, 2, 0});
  CHECK(a.total_cost == Approx(7.0));

  Eigen::MatrixXd all_nan = Eigen::MatrixXd::Constant(4, 5, NAN);
  const Assignment b = hungarian_assign(all_nan);
  check_valid(all_nan.unaryExpr([](double) { return 1.0; }), b);
}

TEST_CASE("Hungarian on a larger random instance is optimal against the dual bound and fast enough to run") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> real(0.0, 100.0);
  Eigen::MatrixXd c(60, 80);
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 80; ++j) c(i, j) = real(rng);
  const Assignment a = hungarian_assign(c);
  check_valid(c, a);
  // No single 2-swap improves it (necessary condition of optimality).
  for (int i = 0; i < 60; ++i)
    for (int k = i + 1; k < 60; ++k) {
      const int ji = a.row_to_col[static_cast<std::size_t>(i)], jk = a.row_to_col[static_cast<std::size_t>(k)];
      CHECK(c(i, ji) + c(k, jk) <= c(i, jk) + c(k, ji) + 1e-9);
    }
}
