// The state of a photo_measurements block (blocks/photo_measurements.cc): image measurements of
// targets and tie points with one camera, the control and scale bars, initialised without
// COLMAP. Private to mmba_adjust.
#pragma once

#include <map>
#include <set>
#include <string>
#include <vector>

#include "mmba/core/ids.h"
#include "mmba/geometry/rigid3d.h"
#include "mmba/io/control_points.h"
#include "mmba/io/image_measurements.h"
#include "mmba/sensors/camera.h"
#include "mmba/io_project/project.h"
#include "mmba/orientation/block_initialisation.h"
#include "mmba/problem/reprojection_group.h"
#include "mmba/problem/problem_builder.h"

namespace mmba::adjust::internal {

/// One control coordinate observed with σ > 0 (x, y or z of a Scene point).
struct ControlCoordinate {
  Point3DId point;
  int axis = 0;
  double value_m = 0.0;
  double sigma_m = 0.0;
  std::string source;  ///< "file:line"
};

struct MeasurementBlock {
  const PhotoMeasurements* config = nullptr;
  CameraId camera_id;
  std::vector<double> initial_params;
  std::vector<std::string> image_names;              ///< by image index (ImageId − base)
  std::map<std::string, ImageId> image_of;           ///< measurement file image id → Scene image
  std::map<std::string, std::string> image_files;    ///< from the images list
  std::map<std::string, Point3DId> point_of;         ///< point id → Scene point
  std::map<Point3DId, std::string> point_name;
  std::vector<ReprojectionObservation> observations;
  std::vector<std::string> sources;                  ///< "file:line" per observation
  std::vector<ControlCoordinate> control;            ///< weighted control coordinates
  std::set<Point3DId> fixed_points;                  ///< control held (σ 0)
  std::map<std::string, Eigen::Vector3d> check_reference;  ///< check points' surveyed coordinates
  std::vector<std::pair<Point3DId, Point3DId>> bar_points;  ///< scale bars' end points
  std::map<ImageId, Rigid3d> initial_poses;
  orientation::BlockResult initial;                  ///< the initialisation's outcome
  bool gauge_needed = false;                         ///< no control: the datum is fixed here
  GaugeOptions gauge;
  std::string datum;                                 ///< how the datum is fixed, in words
  /// Covariance (m², scaled by σ0) of each point the statistics eliminate, in the block's
  /// datum (photo_measurements_datum.cc); the other points' is in the statistics.
  std::map<Point3DId, Eigen::Matrix3d> point_covariance;
  /// With the control as the datum: each eliminated point's x = L·(parameters at `columns` of
  /// the statistics) + its own part, so that Cov(x_i, x_j) = σ0² L_i Q(cols_i, cols_j) L_jᵀ
  /// (report.json relative_precision); empty with an S-transformed datum.
  std::map<Point3DId, std::pair<std::vector<int>, Eigen::MatrixXd>> point_gain;
};

/// The image measurements of the sensor's gcp_list (blocks/photo_measurements_gcp.cc), each
/// image named as the images list or the measurement files name it; InputError naming the
/// gcp_list's line for an image the sensor does not have.
void AppendGcpMeasurements(const PhotoMeasurements& p, const sensors::Camera& camera,
                           const std::map<std::string, std::string>& image_files, std::vector<io::ImageMeasurement>* all);
/// The gcp_lists' points as control (world frame, σ = sigma_m, fixed at 0); InputError for a
/// point also in the control file.
void AppendGcpControl(const Project& project, std::map<std::string, io::ControlPoint>* control);

}  // namespace mmba::adjust::internal
