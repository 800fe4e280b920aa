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

std::string RepresentationName(Representation representation) {
  switch (representation) {
    case Representation::kIntensity: return "intensity";
    case Representation::kPoints: return "points";
    case Representation::kDepth: return "depth";
  }
  return "";
}

bool ParseRepresentation(const std::string& name, Representation* representation) {
  for (Representation r : {Representation::kIntensity, Representation::kPoints,
                           Representation::kDepth}) {
    if (name == RepresentationName(r)) {
      *representation = r;
      return true;
    }
  }
  return false;
}

std::string ViewKindName(ViewKind kind) {
  switch (kind) {
    case ViewKind::kImage: return "image";
    case ViewKind::kPerspective: return "perspective";
    case ViewKind::kCube: return "cube";
  }
  return "";
}

bool ParseViewKind(const std::string& name, ViewKind* kind) {
  if (name == "image" || name == "equirect") {
    *kind = ViewKind::kImage;
  } else if (name == "perspective") {
    *kind = ViewKind::kPerspective;
  } else if (name == "cube") {
    *kind = ViewKind::kCube;
  } else {
    return false;
  }
  return true;
}

bool ViewOptions::Check(std::string* error) const {
  if (perspective_width < 8 || perspective_height < 8) {
    *error = "perspective view size " + std::to_string(perspective_width) + "x" +
             std::to_string(perspective_height) + " must be at least 8x8";
    return false;
  }
  if (!(perspective_hfov_deg > 1 && perspective_hfov_deg < 170)) {
    *error = "perspective_hfov_deg " + std::to_string(perspective_hfov_deg) +
             " must be in (1, 170)";
    return false;
  }
  if (perspective_yaw_deg.empty()) {
    *error = "perspective_yaw_deg must list at least one heading";
    return false;
  }
  if (cube_face_size < 8) {
    *error = "cube_face_size " + std::to_string(cube_face_size) + " must be >= 8";
    return false;
  }
  return true;
}

bool RenderOptions::Check(std::string* error) const {
  if (!(point_radius_m >= 0)) {
    *error = "point_radius_m " + std::to_string(point_radius_m) + " must be >= 0";
    return false;
  }
  if (max_point_radius_px < 0 || max_point_radius_px > 16) {
    *error = "max_point_radius_px " + std::to_string(max_point_radius_px) +
             " must be in 0..16";
    return false;
  }
  if (!(min_range_m > 0) || !(max_range_m > min_range_m)) {
    *error = "ranges must satisfy 0 < min_range_m < max_range_m (found " +
             std::to_string(min_range_m) + ", " + std::to_string(max_range_m) + ")";
    return false;
  }
  return true;
}

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

namespace {

Eigen::Matrix3d RotationAboutY(double angle_rad) {
  return Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
}

// Perspective cut of an equirectangular panorama looking `yaw_deg` right of its centre.
View CutPerspective(const GrayImage& pano, const sensors::Camera& pano_camera, int width,
                    int height, double hfov_deg, double yaw_deg, const std::string& name) {
  View view;
  view.name = name;
  const double f = 0.5 * width / std::tan(0.5 * hfov_deg * M_PI / 180.0);
  view.camera.model_id = sensors::CameraModelId::kPinhole;
  view.camera.width = width;
  view.camera.height = height;
  view.camera.params = {f, f, 0.5 * width, 0.5 * height};
  const Eigen::Matrix3d cam_from_view = RotationAboutY(yaw_deg * M_PI / 180.0);
  view.view_from_cam = cam_from_view.transpose();
  view.image_pixels_per_pixel = pano_camera.params[0] / f;  // equirect f = columns per radian
  view.image_camera = pano_camera;
  view.image = GrayImage(width, height);
  const double* params = pano_camera.params.data();
  const double period = 2.0 * M_PI * params[0];
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      const Eigen::Vector3d ray_in_view((c + 0.5 - 0.5 * width) / f,
                                        (r + 0.5 - 0.5 * height) / f, 1.0);
      const Eigen::Vector3d ray_in_cam = cam_from_view * ray_in_view;
      double xy[2] = {0.0, 0.0};
      sensors::EquirectangularModel::ImgFromCam(params, ray_in_cam.data(), xy);
      if (xy[0] < 0.5) xy[0] += period;
      if (xy[0] > pano.width - 0.5) xy[0] -= period;
      xy[0] = std::clamp(xy[0], 0.5, pano.width - 0.5);
      xy[1] = std::clamp(xy[1], 0.5, pano.height - 0.5);
      float value = 0;
      pano.Sample(xy[0], xy[1], &value);
      view.image.at(c, r) = value;
    }
  }
  return view;
}

constexpr uint64_t kEmptyKey = kEmptyZBufferKey;

inline uint32_t FloatBits(float f) {
  uint32_t bits;
  std::memcpy(&bits, &f, sizeof(bits));
  return bits;
}

// Widest footprint row written as one fixed window (kZBufferPadding entries): radius ≤ 3.
constexpr int kWindow = static_cast<int>(kZBufferPadding);

// Pass 1 of the z-buffer: each point is projected once and its footprint keeps, per pixel,
// the smallest key (range << 32 | index). Positive IEEE floats order as their bit patterns,
// so one 64-bit comparison resolves depth (ties: lower index) without touching the outputs.
template <typename Model>
[[gnu::always_inline]] inline void SplatWithModel(const LidarPoints& points, const View& view,
                                                  const Rigid3d& cam_from_lidar,
                                                  const RenderOptions& options,
                                                  size_t point_begin, size_t point_end,
                                                  uint64_t* zbuffer, LidarImage* out) {
  const int width = out->width;
  const int height = out->height;
  const ViewTransform view_from_lidar = MakeTransform(view, cam_from_lidar);
  const Eigen::Matrix3f& rotation = view_from_lidar.rotation;
  const Eigen::Vector3f& translation = view_from_lidar.translation;
  const double* params = view.camera.params.data();
  const double focal = view.camera.MeanFocalLength();
  const float min_range2 = static_cast<float>(options.min_range_m * options.min_range_m);
  const float max_range2 = static_cast<float>(options.max_range_m * options.max_range_m);
  const float radius_factor = static_cast<float>(options.point_radius_m * focal);
  const int max_radius = options.max_point_radius_px;
  constexpr bool kPerspective = Model::kModelId != sensors::CameraModelId::kEquirectangular;
  const double period = 2.0 * M_PI * params[0];  // panorama columns per turn (f = W/2π)
  Eigen::Vector2f* projected = out->projected.data();
  const bool ranked = !points.tie_rank.empty();
  // One point that passed the projection: its footprint into the z-buffer. (Inlined: as a
  // call it would be compiled for the default instruction set, not the clone's.)
  // `range` = √range2, `radius_px` = radius_factor / range.
  auto draw = [&](size_t i, float range, float radius_px,
                  const double* xy) __attribute__((always_inline)) {
    const int col = static_cast<int>(xy[0]);
    const int row = static_cast<int>(xy[1]);
    const int radius = std::min(max_radius, static_cast<int>(radius_px));
    projected[i] = Eigen::Vector2f(static_cast<float>(xy[0]), static_cast<float>(xy[1]));
    const uint32_t rank = ranked ? points.tie_rank[i] : static_cast<uint32_t>(i);
    const uint64_t key = (static_cast<uint64_t>(FloatBits(range)) << 32) | rank;
    const int r0 = std::max(0, row - radius), r1 = std::min(height - 1, row + radius);
    const int c0 = std::max(0, col - radius), c1 = std::min(width - 1, col + radius);
    if (c1 - c0 < kWindow) {
      // A fixed window per row, the empty key past the footprint (a pixel keeps its key;
      // the buffer is padded for the last row): no branch on the footprint's width, and
      // a loop the compiler vectorises. The same minimum per pixel as the loop below.
      const int n = c1 - c0 + 1;
      for (int r = r0; r <= r1; ++r) {
        uint64_t* cell = zbuffer + static_cast<size_t>(r) * width + c0;
        for (int j = 0; j < kWindow; ++j) cell[j] = std::min(cell[j], j < n ? key : kEmptyKey);
      }
      return;
    }
    for (int r = r0; r <= r1; ++r) {
      uint64_t* line = zbuffer + static_cast<size_t>(r) * width;
      for (int c = c0; c <= c1; ++c) line[c] = std::min(line[c], key);
    }
  };
  if constexpr (std::is_same_v<Model, sensors::PinholeModel>) {
    // The pinhole camera (perspective cuts, KITTI): the points transformed and projected a
    // block at a time in loops without branches, which the compiler vectorises (the
    // divisions in double are most of a point's cost), then the checks and footprints one by
    // one. The same arithmetic as the loop below — Eigen's 3×3 product is r₀x + (r₁y + r₂z)
    // per row, the squared norm x² + (y² + z²) (test ProjectionBlocksEqualTheEigenExpressions),
    // PinholeModel::ImgFromCam is f·(x/z + 0) + c.
    constexpr int kBlock = 64;
    alignas(64) float bz[kBlock], b2[kBlock];
    alignas(64) double bu[kBlock], bv[kBlock];
    const internal::PinholeBlockProjection projection(rotation, translation, params);
    for (size_t begin = point_begin; begin < point_end; begin += kBlock) {
      const int n = static_cast<int>(std::min<size_t>(kBlock, point_end - begin));
      static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "packed points");
      const float* xyz = points.points_in_lidar[begin].data();
      projection.Project<3>(xyz, xyz + 1, xyz + 2, n, bz, b2, bu, bv);
      for (int j = 0; j < n; ++j) {
        if (!(bz[j] > 0.f)) continue;
        const float range2 = b2[j];
        if (range2 < min_range2 || range2 > max_range2) continue;
        if (!(static_cast<double>(bz[j]) > std::numeric_limits<double>::epsilon())) continue;
        const double xy[2] = {bu[j], bv[j]};
        if (!(xy[0] >= 0 && xy[1] >= 0 && xy[0] < width && xy[1] < height)) continue;
        // (The square root stays here: std::sqrt may set errno, which keeps GCC from
        // vectorising the loop above — measured: the block then ran scalar, slower.)
        const float range = std::sqrt(range2);
        draw(begin + j, range, radius_factor / range, xy);
      }
    }
    return;
  }
  for (size_t i = point_begin; i < point_end; ++i) {
    const Eigen::Vector3f p = rotation * points.points_in_lidar[i] + translation;
    if (kPerspective && !(p.z() > 0.f)) continue;
    const float range2 = p.squaredNorm();
    if (range2 < min_range2 || range2 > max_range2) continue;
    const double point_in_view[3] = {p.x(), p.y(), p.z()};
    double xy[2];
    if (!Model::ImgFromCam(params, point_in_view, xy)) continue;
    if (!kPerspective) {  // the ±180° seam: wrap the column into the panorama
      if (xy[0] >= width) xy[0] -= period;
      if (xy[0] < 0) xy[0] += period;
    }
    if (!(xy[0] >= 0 && xy[1] >= 0 && xy[0] < width && xy[1] < height)) continue;
    const float range = std::sqrt(range2);
    draw(i, range, radius_factor / range, xy);
  }
}

// Points [begin, end) of one view into `zbuffer`; one function per instruction set (AVX2
// where the CPU has it: the footprint windows as vectors; no FMA, so the same arithmetic).
__attribute__((target_clones("avx2", "default"))) void Splat(
    const LidarPoints& points, const View& view, const Rigid3d& cam_from_lidar,
    const RenderOptions& options, size_t begin, size_t end, uint64_t* zbuffer,
    LidarImage* out) {
  switch (view.camera.model_id) {
#define MMBA_RENDER_CASE(Model)                                                            \
  case Model::kModelId:                                                                    \
    SplatWithModel<Model>(points, view, cam_from_lidar, options, begin, end, zbuffer, out); \
    break;
    MMBA_FOR_EACH_CAMERA_MODEL(MMBA_RENDER_CASE)
#undef MMBA_RENDER_CASE
    default:
      LOG(FATAL) << "unknown camera model";
  }
}

}  // namespace

View MakeRigCameraView(const GrayImage& image, const sensors::Camera& camera,
                       const Rigid3d& cam_from_rig, const std::string& source) {
  View view = MakeViews(image, camera, ViewOptions(), source)[0];
  view.view_from_cam = cam_from_rig.rotation.toRotationMatrix();
  view.view_from_cam_t = cam_from_rig.translation;
  return view;
}

size_t CountPointsInView(const LidarPoints& points, const View& view,
                         const Rigid3d& cam_from_lidar, const RenderOptions& render,
                         size_t limit) {
  const ViewTransform transform = MakeTransform(view, cam_from_lidar);
  const Eigen::Matrix3d rotation = transform.rotation.cast<double>();
  const Eigen::Vector3d translation = transform.translation.cast<double>();
  size_t seen = 0;
  for (size_t i = 0; i < points.size() && seen < limit; ++i) {
    const Eigen::Vector3d p = rotation * points.points_in_lidar[i].cast<double>() + translation;
    const double range = p.norm();
    if (range < render.min_range_m || range > render.max_range_m) continue;
    const std::optional<Eigen::Vector2d> xy = view.camera.ImgFromCam(p);
    seen += xy && (*xy)[0] >= 0 && (*xy)[1] >= 0 && (*xy)[0] < view.camera.width &&
            (*xy)[1] < view.camera.height;
  }
  return seen;
}

std::vector<View> MakeViews(const GrayImage& image, const sensors::Camera& camera,
                            const ViewOptions& options, const std::string& source) {
  std::string error;
  if (!options.Check(&error)) throw InputError::Message(source, error);
  if (image.width != static_cast<int>(camera.width) ||
      image.height != static_cast<int>(camera.height)) {
    throw InputError::Message(
        source, "image is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                    " but the camera is " + std::to_string(camera.width) + "x" +
                    std::to_string(camera.height));
  }
  std::vector<View> views;
  if (options.kind == ViewKind::kImage) {
    View view;
    view.camera = camera;
    view.image = image;
    view.name = "image";
    views.push_back(std::move(view));
    return views;
  }
  if (camera.model_id != sensors::CameraModelId::kEquirectangular) {
    throw InputError::Message(source, "view '" + ViewKindName(options.kind) +
                                          "' needs an EQUIRECTANGULAR camera, found " +
                                          camera.ModelName());
  }
  if (options.kind == ViewKind::kPerspective) {
    for (double yaw : options.perspective_yaw_deg) {
      views.push_back(CutPerspective(image, camera, options.perspective_width,
                                     options.perspective_height, options.perspective_hfov_deg,
                                     yaw, "perspective_" + std::to_string(int(std::lround(yaw)))));
    }
  } else {
    for (double yaw : {0.0, 90.0, 180.0, 270.0}) {
      views.push_back(CutPerspective(image, camera, options.cube_face_size,
                                     options.cube_face_size, 90.0, yaw,
                                     "cube_" + std::to_string(int(yaw))));
    }
  }
  return views;
}

std::vector<double> SelectPerspectiveHeadings(const LidarPoints& points,
                                              const sensors::Camera& panorama_camera,
                                              const Rigid3d& cam_from_lidar,
                                              const ViewOptions& options,
                                              const RenderOptions& render, int count,
                                              int candidates) {
  CHECK(panorama_camera.IsSpherical()) << "heading selection needs an equirectangular camera";
  CHECK_GT(candidates, 0);
  const int width = std::max(8, options.perspective_width / 4);
  const int height = std::max(8, options.perspective_height / 4);
  const double f = 0.5 * width / std::tan(0.5 * options.perspective_hfov_deg * M_PI / 180.0);
  std::vector<std::pair<double, double>> scored;  // (covered fraction, heading)
  LidarImage lidar;
  for (int k = 0; k < candidates; ++k) {
    const double yaw = -180.0 + 360.0 * k / candidates;
    View view;
    view.camera.model_id = sensors::CameraModelId::kPinhole;
    view.camera.width = width;
    view.camera.height = height;
    view.camera.params = {f, f, 0.5 * width, 0.5 * height};
    view.view_from_cam = RotationAboutY(yaw * M_PI / 180.0).transpose();
    RenderLidarImage(points, view, cam_from_lidar, render, &lidar);
    scored.emplace_back(static_cast<double>(lidar.covered_pixels) / (width * height), yaw);
  }
  std::stable_sort(scored.begin(), scored.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<double> chosen;
  for (const auto& [fraction, yaw] : scored) {
    if (static_cast<int>(chosen.size()) >= count) break;
    bool apart = true;
    for (double c : chosen) {
      const double d = std::abs(std::remainder(yaw - c, 360.0));
      apart = apart && d >= options.perspective_hfov_deg - 1e-9;
    }
    if (apart) chosen.push_back(yaw);
  }
  return chosen;
}

View DownsampleView(const View& view) {
  View half;
  half.name = view.name;
  half.view_from_cam = view.view_from_cam;
  half.view_from_cam_t = view.view_from_cam_t;
  half.image_pixels_per_pixel = 2.0 * view.image_pixels_per_pixel;
  half.image_camera = view.image_camera;
  half.image = Downsample2(view.image);
  half.camera = view.camera;
  half.camera.width = half.image.width;
  half.camera.height = half.image.height;
  // Pixel coordinates scale with the image when the top-left corner is the origin (COLMAP).
  const double sx = static_cast<double>(half.image.width) / view.image.width;
  const double sy = static_cast<double>(half.image.height) / view.image.height;
  const double s = 0.5 * (sx + sy);
  for (int i : sensors::CameraModelFocalIdxs(view.camera.model_id)) half.camera.params[i] *= s;
  const std::vector<int> principal = sensors::CameraModelPrincipalIdxs(view.camera.model_id);
  if (principal.size() == 2) {
    half.camera.params[principal[0]] *= sx;
    half.camera.params[principal[1]] *= sy;
  }
  return half;
}

void RenderLidarZBuffer(const LidarPoints& points, const View& view,
                        const Rigid3d& cam_from_lidar, const RenderOptions& options,
                        LidarImage* out, bool two_threads) {
  CHECK(options.representation != Representation::kIntensity || points.has_intensity() ||
        points.size() == 0)
      << "intensity representation of a cloud without intensity";
  CHECK_LT(points.size(), size_t{1} << 32) << "at most 2^32 points per render";
  CHECK(points.tie_rank.empty() || (points.tie_rank.size() == points.size() &&
                                    points.index_of_rank.size() == points.size()))
      << "tie_rank and index_of_rank must both be empty or both have one entry per point";
  out->width = static_cast<int>(view.camera.width);
  out->height = static_cast<int>(view.camera.height);
  const size_t pixels = static_cast<size_t>(out->width) * out->height;
  out->zbuffer.assign(pixels + kZBufferPadding, kEmptyKey);
  if (out->projected.size() < points.size()) out->projected.resize(points.size());
  if (two_threads && points.size() >= 2) {
    out->zbuffer_second.assign(pixels + kZBufferPadding, kEmptyKey);
    const size_t half = points.size() / 2;
    // `projected` is written per point: the two ranges are disjoint.
    std::thread other([&] {
      Splat(points, view, cam_from_lidar, options, half, points.size(),
            out->zbuffer_second.data(), out);
    });
    Splat(points, view, cam_from_lidar, options, 0, half, out->zbuffer.data(), out);
    other.join();
    // The minimum is order-independent: the same key per pixel as one thread's render.
    for (size_t k = 0; k < pixels; ++k) {
      out->zbuffer[k] = std::min(out->zbuffer[k], out->zbuffer_second[k]);
    }
  } else {
    Splat(points, view, cam_from_lidar, options, 0, points.size(), out->zbuffer.data(), out);
  }
}

LidarValueMap::LidarValueMap(const RenderOptions& options)
    : representation_(options.representation),
      log_min_(static_cast<float>(std::log(options.min_range_m))),
      inv_log_span_(static_cast<float>(
          1.0 / (std::log(options.max_range_m) - std::log(options.min_range_m)))) {}

void RenderLidarImage(const LidarPoints& points, const View& view, const Rigid3d& cam_from_lidar,
                      const RenderOptions& options, LidarImage* out, bool two_threads) {
  RenderLidarZBuffer(points, view, cam_from_lidar, options, out, two_threads);
  const size_t pixels = static_cast<size_t>(out->width) * out->height;
  // Pass 2: the winner of each pixel gives its value, depth and sub-pixel offset.
  out->value.resize(pixels);
  out->depth.resize(pixels);
  out->offset_x.resize(pixels);
  out->offset_y.resize(pixels);
  out->point_index.resize(pixels);
  const LidarValueMap value_of(options);
  size_t covered = 0;
  for (size_t k = 0; k < pixels; ++k) {
    const uint64_t key = out->zbuffer[k];
    if (key == kEmptyKey) {
      out->value[k] = -1.f;
      out->depth[k] = std::numeric_limits<float>::infinity();
      out->offset_x[k] = 0.f;
      out->offset_y[k] = 0.f;
      out->point_index[k] = -1;
      continue;
    }
    ++covered;
    const uint32_t i = ZBufferPointIndex(points, key);
    const float range = ZBufferRange(key);
    const Eigen::Vector2f& xy = out->projected[i];
    out->value[k] = value_of(points, i, range);
    out->depth[k] = range;
    // Offset of the point from the centre of ITS pixel, shared by its whole footprint.
    out->offset_x[k] = xy.x() - (std::floor(xy.x()) + 0.5f);
    out->offset_y[k] = xy.y() - (std::floor(xy.y()) + 0.5f);
    out->point_index[k] = static_cast<int>(i);
  }
  out->covered_pixels = covered;
}

size_t CountVisiblePoints(const LidarImage& image) {
  std::vector<int> winners;
  winners.reserve(image.covered_pixels);
  for (int index : image.point_index) {
    if (index >= 0) winners.push_back(index);
  }
  std::sort(winners.begin(), winners.end());
  return static_cast<size_t>(std::unique(winners.begin(), winners.end()) - winners.begin());
}

GrayImage LidarImageToGray(const LidarImage& image) {
  GrayImage gray(image.width, image.height);
  for (size_t k = 0; k < image.value.size(); ++k) {
    // (Values of several surface classes are class + fraction: the fraction is shown.)
    const float v = image.value[k];
    gray.pixels[k] = v < 0 ? 0.f : 255.f * (v > 1.f ? v - std::floor(v) : v);
  }
  return gray;
}

}  // namespace mmba::registration::mi
