// DescriptorStore: exact k-NN against brute force, filter callback, ordering.
#include <catch2/catch.hpp>
#include <algorithm>
#include <random>

#include "loopd/descriptor/m2dp.hpp"

using namespace loopd;

TEST_CASE("DescriptorStore::knn equals brute force, nearest first, with the id filter") {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  DescriptorStore store;
  std::vector<Eigen::VectorXf> all;
  for (int i = 0; i < 3000; ++i) {
    Eigen::VectorXf d(192);
    for (int j = 0; j < 192; ++j) d(j) = u(rng);
    d.head(64).normalize();
    d.tail(128).normalize();
    all.push_back(d);
    store.add(1000 + i, d);
  }
  CHECK(store.size() == 3000);
  CHECK(store.dimension() == 192);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXf q = all[static_cast<std::size_t>(trial * 97)] + Eigen::VectorXf::Constant(192, 0.001f * trial);
    auto filter = [](std::int64_t id) { return id % 3 != 0; };
    std::vector<std::pair<float, std::int64_t>> brute;
    for (std::size_t i = 0; i < all.size(); ++i)
      if (filter(1000 + static_cast<std::int64_t>(i))) brute.emplace_back(descriptor_distance(q, all[i]), 1000 + static_cast<std::int64_t>(i));
    std::sort(brute.begin(), brute.end());
    const auto nn = store.knn(q, 7, filter);
    REQUIRE(nn.size() == 7);
    for (int k = 0; k < 7; ++k) {
      CHECK(nn[static_cast<std::size_t>(k)].first == brute[static_cast<std::size_t>(k)].second);
      CHECK(nn[static_cast<std::size_t>(k)].second == Approx(brute[static_cast<std::size_t>(k)].first).margin(1e-5));
    }
  }
  // Fewer stored than k, empty filter result, wrong query size.
  DescriptorStore small;
  small.add(1, all[0]);
  small.add(2, all[1]);
  CHECK(small.knn(all[0], 5).size() == 2);
  CHECK(small.knn(all[0], 5)[0].first == 1);
  CHECK(small.knn(all[0], 5, [](std::int64_t) { return false; }).empty());
  CHECK(small.knn(Eigen::VectorXf::Zero(10), 5).empty());
  CHECK(descriptor_distance(all[0], all[0]) == 0.0f);
  CHECK(std::isinf(descriptor_distance(all[0], Eigen::VectorXf::Zero(3))));
}

TEST_CASE("DescriptorStore::knn stays exact on 20,000 clustered descriptors (quantised pre-pass)") {
  // Clusters of near-identical descriptors (revisits of a place differ by ~0.01-0.05): the 8-bit pre-pass alone
  // cannot order them, so the exact pass must decide.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::normal_distribution<float> noise(0.f, 0.002f);
  std::vector<Eigen::VectorXf> centres;
  for (int c = 0; c < 200; ++c) {
    Eigen::VectorXf d(192);
    for (int j = 0; j < 192; ++j) d(j) = u(rng);
    centres.push_back(d);
  }
  DescriptorStore store;
  std::vector<Eigen::VectorXf> all;
  for (int i = 0; i < 20000; ++i) {
    Eigen::VectorXf d = centres[static_cast<std::size_t>(i % 200)];
    for (int j = 0; j < 192; ++j) d(j) += noise(rng);
    d.head(64).normalize();
    d.tail(128).normalize();
    all.push_back(d);
    store.add(i, d);
  }
  for (int trial = 0; trial < 4; ++trial) {
    Eigen::VectorXf q = all[static_cast<std::size_t>(trial * 4999)];
    for (int j = 0; j < 192; ++j) q(j) += noise(rng);
    std::vector<std::pair<float, std::int64_t>> brute;
    for (std::size_t i = 0; i < all.size(); ++i) brute.emplace_back(descriptor_distance(q, all[i]), static_cast<std::int64_t>(i));
    std::sort(brute.begin(), brute.end());
    const auto nn = store.knn(q, 10);
    REQUIRE(nn.size() == 10);
    for (int k = 0; k < 10; ++k) {
      CHECK(nn[static_cast<std::size_t>(k)].first == brute[static_cast<std::size_t>(k)].second);
      CHECK(nn[static_cast<std::size_t>(k)].second == Approx(brute[static_cast<std::size_t>(k)].first).margin(1e-5));
    }
  }
}
