#include "mmba/factors/survey_residual.h"

#include <cmath>

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

namespace mmba::factors {
namespace {

using Row = SurveyRow;

// Parameters: 0 = station xy, 1 = station z, 2 = target xy, 3 = target z, 4 = orientation,
// 5 = second target xy.
struct Params {
  double a_xy[2] = {100.0, 200.0};
  double a_z[1] = {10.0};
  double b_xy[2] = {130.0, 240.0};  // ΔE = 30, ΔN = 40: distance 50, bearing atan2(30, 40)
  double b_z[1] = {22.0};
  double orientation[1] = {0.3};
  double c_xy[2] = {60.0, 200.0};   // due west of the station
  std::vector<double*> blocks() { return {a_xy, a_z, b_xy, b_z, orientation, c_xy}; }
};

Row Base(Row::Kind kind, double value) {
  Row r;
  r.kind = kind;
  r.value = value;
  r.from_xy = 0;
  r.from_z = 1;
  r.to_xy = 2;
  r.to_z = 3;
  r.orientation = 4;
  r.fs_xy = 5;
  return r;
}

double Residual(const Row& row, Params& p, const Eigen::Matrix2d& m = Eigen::Matrix2d::Identity()) {
  std::vector<double*> b = p.blocks();
  return SurveyRowResidual<double>(row, m, b.data());
}

TEST(SurveyResidual, HandComputedValues) {
  Params p;
  const double bearing = std::atan2(30.0, 40.0);
  EXPECT_NEAR(Residual(Base(Row::kDistance, 49.9), p), 0.1, 1e-12);
  EXPECT_NEAR(Residual(Base(Row::kAzimuth, bearing - 1e-4), p), 1e-4, 1e-12);
  EXPECT_NEAR(Residual(Base(Row::kDirection, bearing - 0.3), p), 0.0, 1e-12);
  // Angle from the target (bs) clockwise to the point due west (fs): 270° − bearing.
  EXPECT_NEAR(Residual(Base(Row::kAngle, 1.5 * M_PI - bearing), p), 0.0, 1e-12);
  Row slope = Base(Row::kSlopeDistance, 0.0);
  slope.from_dh = 1.5;
  slope.to_dh = 1.5;
  EXPECT_NEAR(Residual(slope, p), std::hypot(50.0, 12.0),
              1e-12);
  Row zenith = Base(Row::kZenithAngle, 0.0);
  zenith.from_dh = 1.6;
  zenith.to_dh = 2.0;  // Δh = 22 + 2 − 10 − 1.6 = 12.4
  EXPECT_NEAR(Residual(zenith, p), std::atan2(50.0, 12.4), 1e-12);
  EXPECT_NEAR(Residual(Base(Row::kHeightDiff, 12.0), p), 0.0, 1e-12);
  // Input axes "sw" (x south, y west): E = −y, N = −x.
  Eigen::Matrix2d sw;
  sw << 0, -1, -1, 0;
  Row x = Base(Row::kCoordX, -200.0);
  EXPECT_NEAR(Residual(x, p, sw), 0.0, 1e-12);
  Row dy = Base(Row::kVectorY, -30.0);
  EXPECT_NEAR(Residual(dy, p, sw), 0.0, 1e-12);
  // Angles wrap: an observation 2π away is the same.
  EXPECT_NEAR(Residual(Base(Row::kAzimuth, bearing + 2 * M_PI), p), 0.0, 1e-12);
}

TEST(SurveyResidual, WhitenedBlockGradients) {
  Params p;
  std::vector<Row> rows;
  for (Row::Kind kind : {Row::kDirection, Row::kAngle, Row::kDistance, Row::kSlopeDistance,
                         Row::kZenithAngle, Row::kAzimuth, Row::kHeightDiff, Row::kVectorX,
                         Row::kVectorY, Row::kVectorZ, Row::kCoordX, Row::kCoordZ}) {
    rows.push_back(Base(kind, 0.2));
  }
  const int n = static_cast<int>(rows.size());
  {
    // Observations near their predictions (small residuals, as at a solution).
    std::vector<double*> b = p.blocks();
    for (Row& row : rows) {
      row.value = 0.0;
      row.value = SurveyRowResidual<double>(row, Eigen::Matrix2d::Identity(), b.data()) + 0.01;
    }
  }
  Eigen::MatrixXd cov = Eigen::MatrixXd::Identity(n, n) * 4e-6;
  for (int i = 0; i + 1 < n; ++i) cov(i, i + 1) = cov(i + 1, i) = 1e-6;
  const Eigen::MatrixXd l = cov.llt().matrixL();
  const Eigen::MatrixXd l_inv = l.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd::Identity(n, n));
  std::unique_ptr<ceres::CostFunction> cost(SurveyBlockResidual::Create(
      rows, l_inv, Eigen::Matrix2d::Identity(), {2, 1, 2, 1, 1, 2}));
  std::vector<double*> blocks = p.blocks();
  // Whitening: residual = L⁻¹ · raw.
  std::vector<double> residuals(n);
  cost->Evaluate(blocks.data(), residuals.data(), nullptr);
  Eigen::VectorXd raw(n);
  for (int i = 0; i < n; ++i) raw(i) = SurveyRowResidual<double>(rows[i], Eigen::Matrix2d::Identity(), blocks.data());
  const Eigen::VectorXd expected = l_inv * raw;
  for (int i = 0; i < n; ++i) EXPECT_NEAR(residuals[i], expected(i), 1e-9 * std::abs(expected(i)) + 1e-9);
  ceres::NumericDiffOptions numeric;
  ceres::GradientChecker checker(cost.get(), static_cast<const std::vector<const ceres::Manifold*>*>(nullptr), numeric);
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(blocks.data(), 1e-5, &results)) << results.error_log;
}

}  // namespace
}  // namespace mmba::factors
