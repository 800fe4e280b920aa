// Outputs of a photo_measurements block: images.csv (exterior orientation with σ, per-image
// residual RMS and counts), points.csv (adjusted points with σ and 95 % ellipsoid semi-axes;
// both with the project CRS's columns when the project has a `crs`),
// the camera calibration with σ, and report.json `photo_measurements` (initialisation, datum,
// images, check points with dX, dY, dZ and RMSE per axis and 3-D, the camera's parameters with
// σ and the correlation matrix of the refined ones, pairs with |ρ| > 0.95 flagged).
#include <cmath>
#include <iomanip>
#include <optional>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "../output_support.h"
#include "blocks.h"
#include "photo_measurements.h"

namespace mmba::adjust::internal {
namespace {

using json = nlohmann::json;

/// Scale of a standard-error ellipsoid's semi-axes to its 95 % confidence region (3 degrees
/// of freedom: sqrt of the χ²(3) quantile 7.8147).
constexpr double k95Ellipsoid3d = 2.7955;
/// |ρ| above which two camera parameters are reported as highly correlated (DBAT's 95 %).
constexpr double kHighCorrelation = 0.95;

struct ImageResidual {
  size_t count = 0;
  double sum_squares_px = 0.0;
};

std::map<ImageId, ImageResidual> ResidualsByImage(const JointState& s) {
  std::map<ImageId, ImageResidual> by_image;
  const MeasurementBlock& b = *s.measured;
  const Scene& scene = s.scene;
  const sensors::Camera& camera = scene.Camera(b.camera_id);
  for (const ReprojectionObservation& o : b.observations) {
    const auto xy = camera.ImgFromCam(scene.Image(o.image_id).cam_from_world * scene.Point(o.point3D_id));
    ImageResidual& r = by_image[o.image_id];
    ++r.count;
    if (xy) r.sum_squares_px += (*xy - o.xy).squaredNorm();
  }
  return by_image;
}

json Images(const JointState& s, std::ostringstream* csv) {
  const MeasurementBlock& b = *s.measured;
  const auto residuals = ResidualsByImage(s);
  const std::optional<geodesy::CrsFrame> crs = ProjectCrsFrame(*s.project);
  json images = json::array();
  *csv << "image,file,x_m,y_m,z_m,qw,qx,qy,qz,sigma_x_m,sigma_y_m,sigma_z_m,sigma_rx_deg,sigma_ry_deg,sigma_rz_deg,"
          "observations,rms_px"
       << (crs ? CrsColumns(crs->crs()) : "") << "\n";
  for (size_t i = 0; i < b.image_names.size(); ++i) {
    const ImageId id = b.image_of.at(b.image_names[i]);
    const Rigid3d& pose = s.scene.Image(id).cam_from_world;
    const Eigen::Vector3d c = CameraCentre(pose);
    const Eigen::Vector3d sigma = CentreCovariance(s.statistics, pose).diagonal().cwiseMax(0.0).cwiseSqrt();
    Eigen::Vector3d sigma_rotation = Eigen::Vector3d::Zero();  // about the camera axes, deg
    const double* q = pose.rotation.coeffs().data();
    for (int k = 0; k < 3; ++k) {
      sigma_rotation[k] = kRotationPerTangent * std::sqrt(std::max(0.0, s.statistics.Covariance(q, k, q, k))) * kDeg;
    }
    const auto it = residuals.find(id);
    const size_t n = it == residuals.end() ? 0 : it->second.count;
    const double rms = n ? std::sqrt(it->second.sum_squares_px / (2.0 * n)) : 0.0;
    const std::string file = b.image_files.count(b.image_names[i]) ? b.image_files.at(b.image_names[i]) : "";
    *csv << std::setprecision(10) << b.image_names[i] << "," << file << "," << c.x() << "," << c.y() << "," << c.z() << ","
         << pose.rotation.w() << "," << pose.rotation.x() << "," << pose.rotation.y() << "," << pose.rotation.z() << ","
         << std::setprecision(4) << sigma.x() << "," << sigma.y() << "," << sigma.z() << "," << sigma_rotation.x() << ","
         << sigma_rotation.y() << "," << sigma_rotation.z() << "," << n << "," << rms
         << (crs ? CrsValues(*crs, c) : "") << "\n";
    images.push_back({{"image", b.image_names[i]}, {"file", file}, {"centre_m", Vec(c)}, {"sigma_centre_m", Vec(sigma)},
                      {"sigma_rotation_deg", Vec(sigma_rotation)}, {"observations", n}, {"rms_px", rms}});
  }
  return images;
}

/// points.csv; returns the number of points written.
size_t Points(const JointState& s, std::ostringstream* csv) {
  const MeasurementBlock& b = *s.measured;
  std::map<Point3DId, size_t> rays;
  for (const ReprojectionObservation& o : b.observations) ++rays[o.point3D_id];
  std::set<Point3DId> weighted;
  for (const ControlCoordinate& c : b.control) weighted.insert(c.point);
  const std::optional<geodesy::CrsFrame> crs = ProjectCrsFrame(*s.project);
  *csv << "point,kind,x_m,y_m,z_m,sigma_x_m,sigma_y_m,sigma_z_m,a95_m,b95_m,c95_m,rays"
       << (crs ? CrsColumns(crs->crs()) : "") << "\n";
  for (const auto& [name, id] : b.point_of) {
    const Eigen::Vector3d& x = s.scene.Point(id);
    const Eigen::Matrix3d cov = b.point_covariance.count(id) ? b.point_covariance.at(id) : PointCovariance3(s.statistics, x.data());
    const Eigen::Vector3d axes = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvalues().cwiseMax(0.0).cwiseSqrt();
    const char* kind = b.fixed_points.count(id) ? "control (fixed)" : weighted.count(id) ? "control (weighted)"
                       : b.check_reference.count(name) ? "check" : "tie";
    *csv << name << "," << kind << "," << std::setprecision(10) << x.x() << "," << x.y() << "," << x.z() << ","
         << std::setprecision(4) << std::sqrt(std::max(0.0, cov(0, 0))) << "," << std::sqrt(std::max(0.0, cov(1, 1))) << ","
         << std::sqrt(std::max(0.0, cov(2, 2))) << "," << k95Ellipsoid3d * axes[2] << "," << k95Ellipsoid3d * axes[1] << ","
         << k95Ellipsoid3d * axes[0] << "," << rays[id] << (crs ? CrsValues(*crs, x) : "") << "\n";
  }
  return b.point_of.size();
}

json CheckPoints(const JointState& s) {
  const MeasurementBlock& b = *s.measured;
  json rows = json::array();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  size_t n = 0;
  for (const auto& [name, reference] : b.check_reference) {
    const auto it = b.point_of.find(name);
    if (it == b.point_of.end()) {
      rows.push_back({{"point", name}, {"status", "not intersected"}});
      continue;
    }
    const Eigen::Vector3d d = s.scene.Point(it->second) - reference;
    const Eigen::Vector3d sigma = PointCovariance3(s.statistics, s.scene.Point(it->second).data()).diagonal().cwiseMax(0.0).cwiseSqrt();
    rows.push_back({{"point", name}, {"d_m", Vec(d)}, {"sigma_m", Vec(sigma)}});
    sum += d.cwiseProduct(d);
    ++n;
  }
  json out = {{"points", rows}, {"count", n}};
  if (n) {
    const Eigen::Vector3d rmse = (sum / n).cwiseSqrt();
    out["rmse_m"] = Vec(rmse);
    out["rmse_3d_m"] = std::sqrt(sum.sum() / n);
  }
  return out;
}

/// Covariance of the camera's parameters (ambient, in the model's units, scaled by σ0² as
/// every σ of the report): Σ = J Σ_t Jᵀ with Σ_t the tangent covariance and J the
/// manifold's PlusJacobian (the held parameters' rows are zero).
Eigen::MatrixXd CameraCovariance(const JointState& s, const double* params) {
  const ceres::Problem& problem = s.builder->problem();
  const int n = problem.HasParameterBlock(params) ? problem.ParameterBlockSize(params) : 0;
  if (n == 0 || !s.statistics.IsFree(params)) return Eigen::MatrixXd::Zero(n, n);
  const int m = problem.ParameterBlockTangentSize(params);
  Eigen::MatrixXd tangent(m, m);
  for (int a = 0; a < m; ++a) {
    for (int b = 0; b < m; ++b) tangent(a, b) = s.statistics.Covariance(params, a, params, b);
  }
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> plus(n, m);
  const ceres::Manifold* manifold = problem.GetManifold(params);
  if (manifold) {
    manifold->PlusJacobian(params, plus.data());
  } else {
    plus.setIdentity();
  }
  return plus * tangent * plus.transpose();
}

/// Correlations ρ_ij = Σ_ij / (σ_i σ_j) of the refined parameters (`refined` = their indices),
/// and the pairs with |ρ| above kHighCorrelation, as DBAT's report lists them ("Correlations
/// over 95%"; Börlin & Grussenmeyer 2013, "Bundle adjustment with and without damping",
/// Photogramm. Rec. 28(144)). Each high pair becomes a warning of the run.
json Correlations(const Eigen::MatrixXd& cov, const std::vector<int>& refined, const std::vector<std::string>& names,
                  const std::string& sensor, std::vector<std::string>* warnings) {
  json matrix = json::array(), high = json::array(), refined_names = json::array();
  for (int i : refined) refined_names.push_back(names[i]);
  for (size_t a = 0; a < refined.size(); ++a) {
    json row = json::array();
    for (size_t b = 0; b < refined.size(); ++b) {
      const int i = refined[a], j = refined[b];
      const double d = std::sqrt(cov(i, i) * cov(j, j));
      const double rho = d > 0.0 ? cov(i, j) / d : 0.0;
      row.push_back(rho);
      if (b > a && std::abs(rho) > kHighCorrelation) {
        high.push_back({{"a", names[i]}, {"b", names[j]}, {"rho", rho}});
        std::ostringstream w;
        w << "photo_measurements '" << sensor << "': camera parameters " << names[i] << " and " << names[j]
          << " correlated, rho " << std::fixed << std::setprecision(3) << rho << " (|rho| > " << kHighCorrelation << ")";
        warnings->push_back(w.str());
      }
    }
    matrix.push_back(row);
  }
  return {{"parameters", refined_names}, {"matrix", matrix}, {"threshold", kHighCorrelation}, {"high", high}};
}

/// The camera with σ (calibration/<id>_camera.yaml, report.json `camera` and `outputs`
/// calibrations) and the correlations of its refined parameters.
json Calibration(JointState& s, OutputSink* out, json* correlations) {
  const MeasurementBlock& b = *s.measured;
  const sensors::Camera& camera = s.scene.Camera(b.camera_id);
  const Eigen::MatrixXd cov = CameraCovariance(s, camera.params.data());
  const std::vector<std::string> names = sensors::CameraModelParamNames(camera.model_id);
  const std::set<int> free(b.config->free_intrinsics.begin(), b.config->free_intrinsics.end());
  json parameters = json::array();
  std::ostringstream yaml, sigmas;
  yaml << "# mmba adjust: calibration of photo measurements '" << b.config->id << "', sigma from the adjustment\nmodel: "
       << camera.ModelName() << "\nwidth: " << camera.width << "\nheight: " << camera.height << "\nparams: [";
  std::vector<int> refined;
  for (size_t k = 0; k < camera.params.size(); ++k) {
    const double sigma = cov.rows() ? std::sqrt(std::max(0.0, cov(k, k))) : 0.0;
    const bool is_refined = free.count(static_cast<int>(k)) && sigma > 0.0;
    if (is_refined) refined.push_back(static_cast<int>(k));
    yaml << (k ? ", " : "") << std::setprecision(10) << camera.params[k];
    sigmas << (k ? ", " : "") << std::setprecision(4) << sigma;
    parameters.push_back({{"name", k < names.size() ? names[k] : "p" + std::to_string(k)}, {"initial", b.initial_params[k]},
                          {"adjusted", camera.params[k]}, {"sigma", sigma}, {"refined", is_refined}});
  }
  yaml << "]\nsigma: [" << sigmas.str() << "]\n";
  WriteText(out->stage / "calibration" / (b.config->id + "_camera.yaml"), yaml.str());
  out->calibrations.push_back({{"name", b.config->id + " camera (" + camera.ModelName() + ")"}, {"parameters", parameters}});
  *correlations = Correlations(cov, refined, names, b.config->id, &s.warnings);
  return parameters;
}

}  // namespace

void WritePhotoMeasurementOutputs(JointState& s, OutputSink* out) {
  const MeasurementBlock& b = *s.measured;
  std::ostringstream images_csv, points_csv;
  json images = Images(s, &images_csv);
  Points(s, &points_csv);
  WriteText(out->stage / (b.config->id + "_images.csv"), images_csv.str());
  WriteText(out->stage / (b.config->id + "_points.csv"), points_csv.str());
  json outliers = json::array();
  for (const orientation::InitialOutlier& o : b.initial.outliers) {
    outliers.push_back({{"image", o.image_id}, {"point", o.point_id}, {"error_px", o.error_px}, {"stage", o.stage}});
  }
  json correlations;
  const json camera = Calibration(s, out, &correlations);
  (*out->report)["photo_measurements"] = {
      {"id", b.config->id},
      {"initialisation", {{"frame", b.initial.frame}, {"steps", b.initial.log}, {"left_out", outliers},
                          {"images_not_oriented", b.initial.failed_images}, {"points_not_adjusted", b.initial.failed_points}}},
      {"datum", b.datum},
      {"observations", b.observations.size()},
      {"points", b.point_of.size()},
      {"refine", b.config->refine},
      {"camera", camera},
      {"camera_correlations", correlations},
      {"images", images},
      {"check_points", CheckPoints(s)},
      {"files", {b.config->id + "_images.csv", b.config->id + "_points.csv", "calibration/" + b.config->id + "_camera.yaml"}}};
}

}  // namespace mmba::adjust::internal
