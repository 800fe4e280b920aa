// The LiDAR points as the metric sees them (lidar_image.h): intensity stretched and corrected
// for the angle of incidence, local plane normals, and the surface and orientation classes.
#include "mmba/registration/mi/lidar_image.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <thread>
#include <type_traits>
#include <unordered_map>

#include <Eigen/Eigenvalues>
#include <glog/logging.h>

#include "mmba/core/error.h"
#include "registration/mi/pinhole_block.h"

namespace mmba::registration::mi {

namespace {

// Stretch between the 1st and 99th percentile: raw reflectance scales differ between
// scanners (0..1, 0..255, 0..65535) and a few specular returns would crush the rest.
void StretchIntensity(const std::vector<float>& raw, LidarPoints* prepared) {
  std::vector<float> sorted = raw;
  const size_t lo_i = sorted.size() / 100;
  const size_t hi_i = sorted.size() - 1 - sorted.size() / 100;
  std::nth_element(sorted.begin(), sorted.begin() + lo_i, sorted.end());
  const float lo = sorted[lo_i];
  std::nth_element(sorted.begin(), sorted.begin() + hi_i, sorted.end());
  const float hi = sorted[hi_i];
  const float scale = hi > lo ? 1.f / (hi - lo) : 0.f;
  prepared->intensity01.resize(raw.size());
  for (size_t i = 0; i < raw.size(); ++i) {
    prepared->intensity01[i] = std::clamp((raw[i] - lo) * scale, 0.f, 1.f);
  }
}

// cos θ of each point's beam on its local plane (0 without a plane).
std::vector<double> IncidenceCosines(const io::PointCloud& cloud, const std::vector<Eigen::Vector3f>& normals,
                                     const IncidenceCorrection& correction) {
  std::vector<double> cosines(cloud.size(), 0.0);
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (normals[i].isZero()) continue;
    const Eigen::Vector3d beam = cloud.points[i] - correction.scanner(i);
    const double range = beam.norm();
    if (range > 0) cosines[i] = std::abs(normals[i].cast<double>().dot(beam)) / range;
  }
  return cosines;
}

// k of I = ρ·cos^k θ (PrepareLidarPoints with an IncidenceCorrection).
IncidenceFit FitIncidenceExponent(const io::PointCloud& cloud, const std::vector<Eigen::Vector3f>& normals,
                                  const std::vector<double>& cosines, const IncidenceCorrection& correction) {
  // Per orientation group: n, Σx, Σy, Σxx, Σxy, Σyy of x = log cos θ, y = log I.
  struct Sums {
    double n = 0, x = 0, y = 0, xx = 0, xy = 0, yy = 0;
  };
  Sums groups[3];
  const double steep = std::cos(M_PI / 4);
  for (size_t i = 0; i < cloud.size(); ++i) {
    const double c = cosines[i];
    if (c < correction.min_cos || !(cloud.intensity[i] > 0.f)) continue;
    const Eigen::Vector3f& n = normals[i];
    // Horizontal; steep faces by the azimuth of their (unsigned) normal in two halves.
    const int g = std::abs(n.z()) >= steep ? 0 : (std::abs(n.x()) >= std::abs(n.y()) ? 1 : 2);
    const double x = std::log(c), y = std::log(static_cast<double>(cloud.intensity[i]));
    Sums& s = groups[g];
    s.n += 1;
    s.x += x;
    s.y += y;
    s.xx += x * x;
    s.xy += x * y;
    s.yy += y * y;
  }
  IncidenceFit fit;
  double sxx = 0, sxy = 0, syy = 0;
  for (const Sums& s : groups) {
    if (s.n < 2) continue;
    fit.points += static_cast<size_t>(s.n);
    sxx += s.xx - s.x * s.x / s.n;
    sxy += s.xy - s.x * s.y / s.n;
    syy += s.yy - s.y * s.y / s.n;
  }
  if (fit.points < 1000 || !(sxx > 0) || !(syy > 0)) return fit;
  fit.correlation = sxy / std::sqrt(sxx * syy);
  fit.exponent = std::clamp(sxy / sxx, 0.0, correction.max_exponent);
  return fit;
}

std::vector<Eigen::Vector3f> FloatPoints(const io::PointCloud& cloud) {
  std::vector<Eigen::Vector3f> points;
  points.reserve(cloud.size());
  for (const Eigen::Vector3d& p : cloud.points) points.push_back(p.cast<float>());
  return points;
}

}  // namespace

LidarPoints PrepareLidarPoints(const io::PointCloud& cloud, const IncidenceCorrection& correction,
                               IncidenceFit* fit, std::vector<Eigen::Vector3f>* normals_out) {
  CHECK(correction.scanner) << "IncidenceCorrection without a scanner";
  LidarPoints prepared;
  prepared.points_in_lidar = FloatPoints(cloud);
  std::vector<Eigen::Vector3f> normals = LocalPlaneNormals(prepared.points_in_lidar, correction.voxel_m);
  IncidenceFit result;
  if (cloud.has_intensity()) {
    const std::vector<double> cosines = IncidenceCosines(cloud, normals, correction);
    result = FitIncidenceExponent(cloud, normals, cosines, correction);
    std::vector<float> raw = cloud.intensity;
    if (result.exponent > 0) {
      // Each point's factor max(cos θ, min_cos)^-k; points without a plane get the median
      // factor of those with one.
      std::vector<float> factor(cloud.size(), 0.f);
      std::vector<float> planar;
      planar.reserve(cloud.size());
      for (size_t i = 0; i < cloud.size(); ++i) {
        if (normals[i].isZero()) continue;
        factor[i] = static_cast<float>(std::pow(std::max<double>(cosines[i], correction.min_cos), -result.exponent));
        planar.push_back(factor[i]);
      }
      float median = 1.f;
      if (!planar.empty()) {
        std::nth_element(planar.begin(), planar.begin() + planar.size() / 2, planar.end());
        median = planar[planar.size() / 2];
      }
      for (size_t i = 0; i < cloud.size(); ++i) raw[i] *= factor[i] > 0.f ? factor[i] : median;
    }
    StretchIntensity(raw, &prepared);
  }
  if (fit != nullptr) *fit = result;
  if (normals_out != nullptr) *normals_out = std::move(normals);
  return prepared;
}

LidarPoints PrepareLidarPoints(const io::PointCloud& cloud) {
  LidarPoints prepared;
  prepared.points_in_lidar = FloatPoints(cloud);
  if (cloud.has_intensity()) {
    StretchIntensity(cloud.intensity, &prepared);
  }
  return prepared;
}

std::vector<Eigen::Vector3f> LocalPlaneNormals(const std::vector<Eigen::Vector3f>& points,
                                               float voxel_m) {
  CHECK(voxel_m > 0.f) << "voxel_m " << voxel_m;
  // Per point, the plane of its voxel at the finest of three scales (voxel_m / 2, voxel_m,
  // 2 voxel_m) that holds a clear plane: fine voxels keep the ground and a wall's foot apart,
  // coarse ones give sparse far ground enough points. Zero = no clear plane yet.
  std::vector<Eigen::Vector3f> normals(points.size(), Eigen::Vector3f::Zero());
  std::vector<char> done(points.size(), 0);
  struct Moments {
    double n = 0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
    Eigen::Vector3f normal = Eigen::Vector3f::Zero();
  };
  std::vector<uint64_t> keys(points.size());
  for (const float size : {0.5f * voxel_m, voxel_m, 2.f * voxel_m}) {
    // Voxel keys: 21 bits per axis (±1,048,576 voxels; farther points share voxels by
    // wrap-around, which only mixes their statistics).
    std::unordered_map<uint64_t, Moments> voxels;
    voxels.reserve(points.size() / 8 + 16);
    for (size_t i = 0; i < points.size(); ++i) {
      if (done[i]) continue;
      const Eigen::Vector3f cell = (points[i] / size).array().floor().matrix();
      uint64_t key = 0;
      for (int a = 0; a < 3; ++a) key = (key << 21) | (static_cast<uint64_t>(static_cast<int64_t>(cell[a])) & 0x1FFFFF);
      keys[i] = key;
      Moments& m = voxels[key];
      // Relative to the voxel's corner: small numbers, so the covariance keeps its digits.
      const Eigen::Vector3d q = (points[i] - cell * size).cast<double>();
      m.n += 1;
      m.sum += q;
      m.outer += q * q.transpose();
    }
    for (auto& [key, m] : voxels) {
      if (m.n >= 6) {
        const Eigen::Vector3d mean = m.sum / m.n;
        const Eigen::Matrix3d covariance = m.outer / m.n - mean * mean.transpose();
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
        eigen.computeDirect(covariance);
        const Eigen::Vector3d l = eigen.eigenvalues();  // ascending
        if (l[1] >= 0.1 * l[2] && l[0] <= 0.25 * l[1]) {
          m.normal = eigen.eigenvectors().col(0).normalized().cast<float>();
        }
      }
    }
    for (size_t i = 0; i < points.size(); ++i) {
      if (done[i]) continue;
      normals[i] = voxels.at(keys[i]).normal;
      done[i] = !normals[i].isZero();
    }
  }
  return normals;
}

std::vector<uint8_t> SurfaceClasses(const std::vector<Eigen::Vector3f>& points,
                                    const Eigen::Vector3f& up, float voxel_m) {
  const Eigen::Vector3d up_unit = up.normalized().cast<double>();
  const std::vector<Eigen::Vector3f> normals = LocalPlaneNormals(points, voxel_m);
  std::vector<uint8_t> classes(points.size(), 1);
  for (size_t i = 0; i < points.size(); ++i) {
    if (normals[i].isZero()) continue;
    classes[i] = std::abs(normals[i].cast<double>().dot(up_unit)) >= std::cos(M_PI / 4) ? 0 : 1;
  }
  return classes;
}

std::vector<uint8_t> OrientationClasses(const std::vector<Eigen::Vector3f>& points,
                                        const std::vector<Eigen::Vector3f>& normals,
                                        const Eigen::Vector3f& up,
                                        const Eigen::Vector3f& viewpoint, int sectors) {
  CHECK(sectors >= 1 && sectors + 3 <= kMaxLidarClasses) << "sectors " << sectors;
  CHECK_EQ(normals.size(), points.size());
  const Eigen::Vector3f z = up.normalized();
  // Azimuths about `up` from the cloud's x axis projected onto the horizontal (its y axis
  // where x is vertical).
  Eigen::Vector3f e1 = Eigen::Vector3f::UnitX() - z * z.x();
  if (e1.norm() < 0.1f) e1 = Eigen::Vector3f::UnitY() - z * z.y();
  e1.normalize();
  const Eigen::Vector3f e2 = z.cross(e1);
  const float steep = static_cast<float>(std::cos(M_PI / 4));
  const double sector = 2.0 * M_PI / sectors;
  std::vector<uint8_t> classes(points.size(), static_cast<uint8_t>(sectors + 2));
  for (size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector3f n = normals[i];
    if (n.isZero()) continue;
    // The side seen from the viewpoint: a surface is lit (and photographed) on that side.
    if (n.dot(viewpoint - points[i]) < 0.f) n = -n;
    const float vertical = n.dot(z);
    if (vertical >= steep) {
      classes[i] = 0;
    } else if (vertical <= -steep) {
      classes[i] = 1;
    } else {
      // Sectors centred on the azimuths 0, 360°/sectors, …: walls along the grid's axes fall
      // in the middle of a sector, not on a boundary.
      const double azimuth = std::atan2(n.dot(e2), n.dot(e1)) + 0.5 * sector;
      const int s = static_cast<int>(std::floor(azimuth / sector));
      classes[i] = static_cast<uint8_t>(2 + ((s % sectors) + sectors) % sectors);
    }
  }
  return classes;
}

void EncodeSurfaceClasses(const std::vector<uint8_t>& classes, LidarPoints* points) {
  CHECK(points->has_intensity() && classes.size() == points->size())
      << "classes " << classes.size() << " for " << points->size() << " points";
  for (size_t i = 0; i < classes.size(); ++i) {
    CHECK_LT(classes[i], kMaxLidarClasses) << "point " << i;
    // Class + fraction (MetricOptions::lidar_classes): the fraction below 1, so that
    // floor(value) is the class.
    points->intensity01[i] =
        static_cast<float>(classes[i]) + 0.999f * std::clamp(points->intensity01[i], 0.f, 1.f);
  }
  points->classes = 1;
  for (uint8_t c : classes) points->classes = std::max(points->classes, c + 1);
}

int EncodeOrientationClasses(const Eigen::Vector3f& viewpoint, int sectors, float voxel_m,
                             LidarPoints* points, std::vector<size_t>* per_class) {
  return EncodeOrientationClasses(viewpoint, sectors, LocalPlaneNormals(points->points_in_lidar, voxel_m),
                                  points, per_class);
}

int EncodeOrientationClasses(const Eigen::Vector3f& viewpoint, int sectors,
                             const std::vector<Eigen::Vector3f>& normals, LidarPoints* points,
                             std::vector<size_t>* per_class) {
  const std::vector<uint8_t> classes =
      OrientationClasses(points->points_in_lidar, normals, Eigen::Vector3f::UnitZ(), viewpoint, sectors);
  EncodeSurfaceClasses(classes, points);
  if (per_class != nullptr) {
    per_class->assign(sectors + 3, 0);
    for (uint8_t c : classes) ++(*per_class)[c];
  }
  return sectors + 3;
}

}  // namespace mmba::registration::mi
