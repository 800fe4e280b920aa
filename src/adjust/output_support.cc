// Helpers of the adjustment's output files (output_support.h).
#include "output_support.h"

#include <algorithm>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>

#include "mmba/geometry/skew.h"
#include "mmba/survey/result_json.h"

namespace mmba::adjust::internal {

nlohmann::json Vec(const Eigen::Vector3d& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); }

Eigen::Matrix3d CentreCovariance(const stats::NetworkStatistics& st, const Rigid3d& cam_from_world) {
  const double* q = cam_from_world.rotation.coeffs().data();
  const double* t = cam_from_world.translation.data();
  if (!st.IsFree(q) && !st.IsFree(t)) return Eigen::Matrix3d::Zero();
  Eigen::Matrix<double, 6, 6> c = Eigen::Matrix<double, 6, 6>::Zero();
  const std::pair<const double*, int> s[6] = {{q, 0}, {q, 1}, {q, 2}, {t, 0}, {t, 1}, {t, 2}};
  for (int a = 0; a < 6; ++a) {
    for (int b = 0; b < 6; ++b) c(a, b) = st.Covariance(s[a].first, s[a].second, s[b].first, s[b].second);
  }
  const Eigen::Matrix3d rt = cam_from_world.rotation.toRotationMatrix().transpose();
  Eigen::Matrix<double, 3, 6> j;
  j << -kRotationPerTangent * rt * Skew(cam_from_world.translation), -rt;
  return j * c * j.transpose();
}

std::vector<double> ParameterSigmas(const stats::NetworkStatistics& st, const ceres::Problem& problem,
                                    const double* block) {
  if (!problem.HasParameterBlock(block)) return std::vector<double>(3, 0.0);
  const int n = problem.ParameterBlockSize(block);
  std::vector<double> sigma(n, 0.0);
  if (!st.IsFree(block)) return sigma;
  const int m = problem.ParameterBlockTangentSize(block);
  Eigen::MatrixXd tangent(m, m);
  for (int a = 0; a < m; ++a) {
    for (int b = 0; b < m; ++b) tangent(a, b) = st.Covariance(block, a, block, b);
  }
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> plus(n, m);
  const ceres::Manifold* manifold = problem.GetManifold(block);
  if (manifold) {
    manifold->PlusJacobian(block, plus.data());
  } else {
    plus.setIdentity();
  }
  const Eigen::MatrixXd ambient = plus * tangent * plus.transpose();
  for (int i = 0; i < n; ++i) sigma[i] = std::sqrt(std::max(0.0, ambient(i, i)));
  return sigma;
}

Eigen::Matrix3d PointCovariance3(const stats::NetworkStatistics& st, const double* p) {
  Eigen::Matrix3d c;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) c(a, b) = st.Covariance(p, a, p, b);
  }
  return c;
}

Eigen::Matrix<double, 6, 6> ComposedPoseCovariance(const stats::NetworkStatistics& st, const Rigid3d& a, const Rigid3d& b) {
  const double* blocks[4] = {a.rotation.coeffs().data(), a.translation.data(), b.rotation.coeffs().data(),
                             b.translation.data()};
  Eigen::Matrix<double, 12, 12> c;
  for (int i = 0; i < 12; ++i) {
    for (int j = 0; j < 12; ++j) c(i, j) = st.Covariance(blocks[i / 3], i % 3, blocks[j / 3], j % 3);
  }
  const Rigid3d base = a * b;
  const auto perturbed = [&](int k, double h) {
    Rigid3d pa = a, pb = b;
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d[k % 3] = h;
    const Eigen::Quaterniond turn(Eigen::AngleAxisd(kRotationPerTangent * d.norm(), d.normalized()));
    if (k < 3) pa.rotation = turn * a.rotation;
    else if (k < 6) pa.translation += d;
    else if (k < 9) pb.rotation = turn * b.rotation;
    else pb.translation += d;
    const Rigid3d p = pa * pb;
    const Eigen::AngleAxisd rot(p.rotation * base.rotation.conjugate());
    Eigen::Matrix<double, 6, 1> out;
    out << rot.angle() * rot.axis(), p.translation;
    return out;
  };
  Eigen::Matrix<double, 6, 12> jacobian;
  constexpr double h = 1e-6;
  for (int k = 0; k < 12; ++k) jacobian.col(k) = (perturbed(k, h) - perturbed(k, -h)) / (2 * h);
  return jacobian * c * jacobian.transpose();
}

std::pair<double, double> PoseError(const Rigid3d& estimate, const Rigid3d& truth) {
  return {estimate.rotation.angularDistance(truth.rotation) * kDeg, (estimate.translation - truth.translation).norm()};
}

std::string YamlPose(const Rigid3d& p) {
  std::ostringstream o;
  o << std::setprecision(10) << "{qvec_wxyz: [" << p.rotation.w() << ", " << p.rotation.x() << ", " << p.rotation.y()
    << ", " << p.rotation.z() << "], tvec: [" << p.translation.x() << ", " << p.translation.y() << ", "
    << p.translation.z() << "]}";
  return o.str();
}

nlohmann::json Ellipse(const Eigen::Matrix3d& enu) {
  const stats::ErrorEllipse e = stats::StandardEllipse(enu.topLeftCorner<2, 2>());
  // StandardEllipse's angle is from axis 1 (east) towards axis 2 (north); azimuth is from north
  // clockwise: 90° − angle.
  double azimuth = 90.0 - e.angle_rad * kDeg;
  if (azimuth < 0) azimuth += 180.0;
  return {{"a", Num(e.a)}, {"b", Num(e.b)}, {"azimuth_deg", azimuth}};
}

std::string Geo(const geodesy::LocalTangentPlane& plane, const Eigen::Vector3d& enu) {
  const geodesy::Geodetic g = plane.GeodeticFromEnu(enu);
  const geodesy::Utm u = geodesy::UtmFromGeodetic(g);
  std::ostringstream s;
  s << std::setprecision(10) << g.latitude_deg << "," << g.longitude_deg << "," << std::setprecision(4) << std::fixed
    << g.height_m << "," << u.zone << (u.northp ? "N" : "S") << "," << std::setprecision(4) << u.easting_m << ","
    << u.northing_m;
  return s.str();
}

std::string CrsColumns(const geodesy::Crs& crs) {
  std::string tag = crs.identifier();
  if (tag.rfind("EPSG:", 0) == 0) {
    tag = "epsg" + tag.substr(5);
    std::replace(tag.begin(), tag.end(), '+', '_');
  } else {
    tag = "crs";
  }
  if (crs.is_geographic()) return ",longitude_" + tag + "_deg,latitude_" + tag + "_deg,height_" + tag + "_m";
  return ",easting_" + tag + "_m,northing_" + tag + "_m,height_" + tag + "_m";
}

std::string CrsValues(const geodesy::CrsFrame& frame, const Eigen::Vector3d& point_in_world) {
  const Eigen::Vector3d xyz = frame.CrsFromWorld(point_in_world);
  std::ostringstream s;
  s << std::fixed << std::setprecision(frame.crs().is_geographic() ? 10 : 4) << "," << xyz.x() << "," << xyz.y()
    << std::setprecision(4) << "," << xyz.z();
  return s.str();
}

nlohmann::json CrsJson(const geodesy::Crs& crs) {
  nlohmann::json json = survey::CrsToJson(crs);
  json["columns"] = CrsColumns(crs).substr(1);
  return json;
}

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

void AppendPoseRow(std::ostream& poses, const std::string& name, const std::string& sensor, const Eigen::Vector3d& c,
                   const Eigen::Quaterniond& q, const geodesy::LocalTangentPlane& plane, const Eigen::Vector3d& sigma,
                   double d_position_m, double d_rotation_deg) {
  poses << name << "," << sensor << "," << std::setprecision(12) << c.x() << "," << c.y() << "," << c.z() << ","
        << q.w() << "," << q.x() << "," << q.y() << "," << q.z() << "," << Geo(plane, c) << "," << std::setprecision(6)
        << sigma.x() << "," << sigma.y() << "," << sigma.z() << "," << d_position_m << "," << d_rotation_deg << "\n";
}

}  // namespace mmba::adjust::internal
