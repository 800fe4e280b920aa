#include <gtest/gtest.h>

#include "mmba/adjust/adjust.h"

namespace mmba::adjust {
namespace {

// The names are the text of report.json's "status" and of the CLI's failure line.
TEST(AdjustStatus, NamesAreTheReportText) {
  EXPECT_EQ(AdjustStatusName(AdjustStatus::kConverged), "converged");
  EXPECT_EQ(AdjustStatusName(AdjustStatus::kNoConvergence), "no_convergence");
  EXPECT_EQ(AdjustStatusName(AdjustStatus::kFailed), "failed");
}

}  // namespace
}  // namespace mmba::adjust
