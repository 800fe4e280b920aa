// Pearson's correlation: exact on linear data, sign and scale invariance, undefined cases.
#include "mmba/stats/correlation.h"

#include <cmath>

#include <gtest/gtest.h>

namespace mmba::stats {
namespace {

TEST(Pearson, LinearDataCorrelateFullyAndIndependentOnesNot) {
  std::vector<std::pair<double, double>> up, down, square;
  for (int i = 0; i < 10; ++i) {
    up.emplace_back(i, 3.0 * i + 2.0);
    down.emplace_back(i, -0.5 * i);
    square.emplace_back(i - 4.5, (i - 4.5) * (i - 4.5));  // symmetric: uncorrelated
  }
  EXPECT_NEAR(Pearson(up), 1.0, 1e-12);
  EXPECT_NEAR(Pearson(down), -1.0, 1e-12);
  EXPECT_NEAR(Pearson(square), 0.0, 1e-12);
  // The textbook example: (1,2), (2,4), (3,5), (4,4), (5,5) → r = 0.7746.
  EXPECT_NEAR(Pearson({{1, 2}, {2, 4}, {3, 5}, {4, 4}, {5, 5}}), 0.774597, 1e-6);
  EXPECT_TRUE(std::isnan(Pearson({{1, 2}})));
  EXPECT_TRUE(std::isnan(Pearson({{1, 2}, {2, 2}, {3, 2}})));  // constant side
}

}  // namespace
}  // namespace mmba::stats
