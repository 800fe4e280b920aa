#include "mmba/factors/distance_observation.h"

#include <gtest/gtest.h>

#include "gradient_check.h"

namespace mmba::factors {
namespace {

TEST(DistanceCost, HandComputedAndGradients) {
  // Points 5 m apart (3-4-5), measured 4.9 m with σ = 0.05 m → r = 2.
  const DistanceCost cost(4.9, 0.05);
  const double a[3] = {1, 1, 0}, b[3] = {4, 5, 0};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(cost, {a, b}, &r));
  EXPECT_NEAR(r[0], 2.0, 1e-12);
  ExpectGradientsMatch(cost, {a, b});
  const double c[3] = {0.3, -2.0, 1.7};
  ExpectGradientsMatch(cost, {a, c});
  EXPECT_FALSE(EvaluateCost(cost, {a, a}, &r));  // coincident points
}

}  // namespace
}  // namespace mmba::factors
