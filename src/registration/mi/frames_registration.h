#pragma once

// One registration of a frame set, RegisterFrames' steps: register_frames.cc holds the search
// and the checks of the optimum itself (search end, covariance, predicted σ, shuffled
// baseline), acceptance_checks.cc the checks that re-optimise or calibrate (restarts,
// independent halves, calibrated covariance, per-axis scans).

#include <array>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/core/progress.h"
#include "mmba/registration/mi/mi_registration.h"
#include "registration/mi/mi_internal.h"
#include "registration/mi/search.h"

namespace mmba::registration::mi::internal {

/// The restarts' ends (FramesRegistration::RunRestarts): per restart its search, metric and
/// median pixel distance from the optimum; `reported` of them count (all, or stopping at the
/// first failure those up to the first that ended too far), each of which ran.
struct RestartEnds {
  std::vector<SearchResult> ends;
  std::vector<double> values;
  std::vector<double> distances;
  int reported = 0;
  bool polished = false;  ///< taken from the polish's last round, not searched again
};

/// One independent half's re-optimisation (FramesRegistration::RunHalves): its correction,
/// evaluations, the points it sees and, over them, the median pixel distance from the joint
/// optimum, the sum of squared displacements and of predicted variances (px²).
struct HalfEnd {
  Vector6d x = Vector6d::Zero();
  int evaluations = 0;
  size_t own_points = 0;
  double distance = 0, displacement2 = 0, predicted2 = 0;
};

// One registration of a frame set (RegisterFrames): the search, then the acceptance checks in
// order, each a member function (register_frames.cc, acceptance_checks.cc). Status "ok" needs every check to pass; by default the checks stop
// at the first failure (options.measure_all_checks): Decided() says the status is "failed"
// and the rest is not measured (the status, pose and an ok result's values are the same).
class FramesRegistration {
 public:
  FramesRegistration(const std::vector<Frame>& frames, const Rigid3d& cam_from_lidar_start,
                     const RegistrationOptions& options, const Timer& timer,
                     RegistrationResult* result)
      : frames(frames),
        cam_from_lidar_start(cam_from_lidar_start),
        options(options),
        timer(timer),
        result(*result),
        checks(result->checks),
        clock(result),
        evaluator(frames, cam_from_lidar_start, options),
        bound(BoundVector(options)),
        levels(evaluator.levels()),
        fail_fast(!options.measure_all_checks) {
    clock.Mark("prepare", 0);
  }
  RegistrationResult Run();

 private:
  RegistrationResult Fail(const std::string& reason);
  bool Decided(const char* stage);
  RegistrationResult Finished();
  void SearchAndPolish();
  void SearchEndChecks();
  void LaplaceCovariance();
  void PredictedSigma();
  void WholeImageSigma();
  void ShuffledBaseline();
  void Restarts();
  RestartEnds RunRestarts();
  void RestartImageSpread(const RestartEnds& ends);
  void Halves();
  /// Re-optimises each half (two; the second not reported when fail_fast and the first
  /// disagrees): the halves' ends, `reported` receives how many count.
  std::array<HalfEnd, 2> RunHalves(const std::array<std::vector<Frame>, 2>& halves, int* reported);
  void HalvesImageSpread(const std::array<HalfEnd, 2>& ends, int reported);
  void CalibrateCovariance();
  void AxisScans();

  const std::vector<Frame>& frames;
  const Rigid3d& cam_from_lidar_start;
  const RegistrationOptions& options;
  const Timer& timer;
  RegistrationResult& result;
  AcceptanceChecks& checks;
  StageClock clock;
  FrameSetEvaluator evaluator;
  const Vector6d bound;
  const int levels;
  const bool fail_fast;
  std::vector<std::string> failures;
  PolishResult polish;
  Vector6d x = Vector6d::Zero();  ///< the optimum's correction
  // The Laplace covariance.
  int covariance_level = 0;
  double min_eigen = 0, max_eigen = 0;  ///< of the information
  // The predicted pixel σ over a sample of the visible points.
  std::vector<FrameSetEvaluator::VisiblePoint> sample;
  double predicted_ms = 0;  ///< mean over the sample of trace(J Σ_L Jᵀ), px²
  /// The sample's pixel Jacobians at the optimum (also the covariance's pixel floor).
  std::vector<Eigen::Matrix<double, 2, 6>> sample_jacobians;
  bool sigma_failed = false;
  std::string sigma_failure;
  // The same over the whole image when the views are cuts of it.
  std::vector<ImagePoint> image_sample;
  double image_predicted_ms = 0;  ///< mean over the image sample of trace(J Σ_L Jᵀ), px²
  double image_factor_halves = std::numeric_limits<double>::quiet_NaN();
  double image_factor_restarts = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace mmba::registration::mi::internal
