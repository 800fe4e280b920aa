#include "mmba/geometry/skew.h"

#include <Eigen/Geometry>
#include <ceres/jet.h>
#include <gtest/gtest.h>

namespace mmba {
namespace {

TEST(Skew, HandComputedEntries) {
  const Eigen::Matrix3d m = Skew(Eigen::Vector3d(1.0, 2.0, 3.0));
  Eigen::Matrix3d expected;
  expected << 0.0, -3.0, 2.0,
              3.0, 0.0, -1.0,
              -2.0, 1.0, 0.0;
  EXPECT_EQ(m, expected);
}

TEST(Skew, TimesAVectorIsTheCrossProduct) {
  const Eigen::Vector3d v(0.3, -1.7, 2.2);
  const Eigen::Vector3d w(-4.0, 0.5, 1.25);
  EXPECT_LT((Skew(v) * w - v.cross(w)).norm(), 1e-15);
  EXPECT_LT((Skew(v) + Skew(v).transpose()).norm(), 1e-15);
}

TEST(Skew, TakesMapsAndJets) {
  const double data[3] = {1.0, 2.0, 3.0};
  const Eigen::Map<const Eigen::Vector3d> map(data);
  EXPECT_EQ(Skew(map), Skew(Eigen::Vector3d(1.0, 2.0, 3.0)));

  using Jet = ceres::Jet<double, 3>;
  const Eigen::Matrix<Jet, 3, 1> v(Jet(1.0, 0), Jet(2.0, 1), Jet(3.0, 2));
  const Eigen::Matrix<Jet, 3, 3> m = Skew(v);
  EXPECT_EQ(m(0, 1).a, -3.0);
  EXPECT_EQ(m(0, 1).v(2), -1.0);  // d(-v_z)/d v_z
  EXPECT_EQ(m(2, 1).v(0), 1.0);   // d(v_x)/d v_x
  EXPECT_EQ(m(1, 1).v.norm(), 0.0);
}

}  // namespace
}  // namespace mmba
