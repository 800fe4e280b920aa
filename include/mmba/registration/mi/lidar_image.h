#pragma once

// LiDAR images (Wang, Ferrie & Macfarlane 2012, Sec. 3.1): a cloud rendered from a camera pose
// as an intensity image, a points-only image or a depth map, with a z-buffer whose point
// footprint shrinks with range so that the far side of a wall does not show through.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/registration/mi/image.h"
#include "mmba/sensors/camera.h"

namespace mmba::registration::mi {

/// The paper's three representations of the LiDAR.
enum class Representation { kIntensity, kPoints, kDepth };
std::string RepresentationName(Representation representation);
/// "intensity" | "points" | "depth"; false when unknown.
bool ParseRepresentation(const std::string& name, Representation* representation);

/// A cloud prepared for repeated rendering: float coordinates in the LiDAR frame and a
/// per-point value in [0, 1] for the intensity representation (raw reflectance stretched
/// between its 1st and 99th percentile).
struct LidarPoints {
  std::vector<Eigen::Vector3f> points_in_lidar;
  std::vector<float> intensity01;  ///< empty when the cloud has no intensity
  /// Surface classes carried by intensity01 (EncodeSurfaceClasses: class + fraction); a
  /// registration needs MetricOptions::lidar_classes ≥ this (checked).
  int classes = 1;
  /// Optional, both empty or both size(): each point's rank among equally near points in
  /// the z-buffer (the lower rank wins; empty = the index), and its inverse (rank → index).
  /// FrameSetEvaluator sorts its points for a cache-friendly render and keeps their rank in
  /// the unsorted order here, so that each pixel keeps the winner it had in that order.
  std::vector<uint32_t> tie_rank;
  std::vector<uint32_t> index_of_rank;
  bool has_intensity() const { return !intensity01.empty(); }
  size_t size() const { return points_in_lidar.size(); }
};
LidarPoints PrepareLidarPoints(const io::PointCloud& cloud);

/// Radiometric correction of the LiDAR intensity for the angle of incidence, before the
/// stretch of PrepareLidarPoints. A diffuse (Lambertian) surface returns ρ·cos θ, θ between
/// the beam and the surface normal (the incidence term of the LiDAR range equation for
/// extended targets; Höfle & Pfeifer 2007, "Correction of laser scanning intensity data:
/// data and model-driven approaches", ISPRS J. Photogramm. 62(6); Kashani et al. 2015, "A
/// review of LIDAR radiometric processing", Sensors 15(11)), so a mobile scanner passing a façade at
/// grazing incidence paints it in a pattern of its own trajectory that the photo does not
/// have. Real scanners depart from Lambert (rough surfaces, a factory calibration that already
/// normalises), so the exponent k of I = ρ·cos^k θ is fitted to the cloud itself and the
/// value corrected as I / max(cos θ, min_cos)^k.
struct IncidenceCorrection {
  /// The scanner's centre when point i was measured, in the cloud's frame.
  std::function<Eigen::Vector3d(size_t)> scanner;
  float voxel_m = 0.5f;  ///< LocalPlaneNormals' voxel for θ
  float min_cos = 0.1f;  ///< beams more grazing than 84° are corrected as at 84°
  double max_exponent = 2.0;
};
/// What the correction did (for the log and the JSON).
struct IncidenceFit {
  double exponent = 0.0;   ///< k fitted (0: no correction)
  double correlation = 0;  ///< of log I and log cos θ within the orientation groups
  size_t points = 0;       ///< points in the fit (a plane, cos θ ≥ min_cos, I > 0)
};
/// PrepareLidarPoints with the intensity corrected for incidence (IncidenceCorrection): the
/// raw values divided by max(cos θ, min_cos)^k (points without a plane by the median of the
/// others' factor, so that they stay on the same scale), then stretched. k: least squares of
/// log I on log cos θ with one intercept (log ρ) per orientation group (horizontal, and steep
/// faces in two azimuth halves), so that the different albedo of the ground and the walls,
/// seen at different incidences, is not taken for the incidence's effect; points without a
/// plane, with cos θ < min_cos or I ≤ 0 left out; fewer than 1000 usable points give k = 0
/// (no correction); clamped to [0, max_exponent]. `normals` (optional)
/// receives LocalPlaneNormals of the points, for EncodeOrientationClasses. A cloud without
/// intensity is prepared as by PrepareLidarPoints.
LidarPoints PrepareLidarPoints(const io::PointCloud& cloud, const IncidenceCorrection& correction,
                               IncidenceFit* fit, std::vector<Eigen::Vector3f>* normals = nullptr);

/// The most surface classes a metric can be conditioned on (MetricOptions::lidar_classes).
inline constexpr int kMaxLidarClasses = 16;

/// Per point, the unit normal of the local plane through it (zero where there is none): the
/// PCA plane of the point's cubic voxel at the finest of voxel_m / 2, voxel_m and 2 voxel_m
/// that holds one (≥ 6 points, a second eigenvalue ≥ 10 % of the first and a smallest ≤ 25 %
/// of the second). The sign is arbitrary.
std::vector<Eigen::Vector3f> LocalPlaneNormals(const std::vector<Eigen::Vector3f>& points,
                                               float voxel_m);

/// Surface classes of a cloud, for MI conditioned on the surface (bench/RESULTS.md "Surface
/// classes (opt-in)"): 0 = a horizontal surface (the local plane's normal within 45° of
/// `up`, LocalPlaneNormals), 1 = anything else (walls, and neighbourhoods with no clear plane).
/// Where two kinds of surface relate to the photo differently (ground dark in the LiDAR at
/// grazing incidence but bright in the photo, walls the other way round), the MI of the
/// mixture can peak off the truth while each class alone peaks at it.
std::vector<uint8_t> SurfaceClasses(const std::vector<Eigen::Vector3f>& points,
                                    const Eigen::Vector3f& up, float voxel_m);

/// Orientation classes, for MI conditioned on which way a surface faces (bench/RESULTS.md
/// "Orientation classes"): in sunlight a photo's grey level is albedo × a shading factor of
/// the surface's orientation (Lambert), while the LiDAR's reflectance is not shaded by the
/// sun, so the relation of the two differs between a lit and a shaded face; within one
/// orientation it is one relation. The local plane's normal (LocalPlaneNormals) is turned
/// towards `viewpoint` (the camera: the side that is photographed) and classed: 0 = facing
/// up (within 45° of `up`), 1 = facing down, 2 .. sectors + 1 = steep faces by the azimuth of
/// their normal about `up` in `sectors` equal sectors (centred on the cloud's x axis and
/// multiples of 360°/sectors from it), sectors + 2 = no clear plane (a zero normal).
/// `normals` from LocalPlaneNormals; sectors + 3 ≤ kMaxLidarClasses.
std::vector<uint8_t> OrientationClasses(const std::vector<Eigen::Vector3f>& points,
                                        const std::vector<Eigen::Vector3f>& normals,
                                        const Eigen::Vector3f& up,
                                        const Eigen::Vector3f& viewpoint, int sectors);

/// Puts each point's class into its LiDAR value as class + 0.999 · intensity01, for
/// MetricOptions::lidar_classes = the number of classes, which conditions the metric on the
/// class; sets points->classes to the largest class + 1. Needs intensity and one class
/// (< kMaxLidarClasses) per point.
void EncodeSurfaceClasses(const std::vector<uint8_t>& classes, LidarPoints* points);

/// register-mi's default (--orientation-classes): four azimuth sectors, 7 classes. Measured
/// on the simulated gate and cathedral (bench/RESULTS.md "Orientation classes").
inline constexpr int kDefaultOrientationSectors = 4;

/// OrientationClasses of `points` (normals of voxel_m, LocalPlaneNormals; `up` = the frame's
/// z axis) seen from `viewpoint` (in the points' frame: the camera's or rig's centre),
/// encoded into their values (EncodeSurfaceClasses). Returns the number of classes,
/// sectors + 3, for MetricOptions::lidar_classes; `per_class` (optional) the points of each.
int EncodeOrientationClasses(const Eigen::Vector3f& viewpoint, int sectors, float voxel_m,
                             LidarPoints* points, std::vector<size_t>* per_class = nullptr);
/// The same with the points' LocalPlaneNormals already computed (one per point).
int EncodeOrientationClasses(const Eigen::Vector3f& viewpoint, int sectors,
                             const std::vector<Eigen::Vector3f>& normals, LidarPoints* points,
                             std::vector<size_t>* per_class = nullptr);

/// One rendered view: a camera (any mmba model) and the rotation of this view relative to
/// the frame's image camera (identity for the image itself; a perspective cut of a panorama
/// is rotated). The grey image is the part of the photo/panorama seen by this view.
struct View {
  sensors::Camera camera;
  Eigen::Matrix3d view_from_cam = Eigen::Matrix3d::Identity();
  /// With view_from_cam: p_view = view_from_cam · p_cam + view_from_cam_t. Zero for the cuts
  /// of a panorama (they share its centre); a rig camera's offset from the rig frame
  /// (cam_from_rig) when the views are the rig's own cameras and the pose is the rig's.
  Eigen::Vector3d view_from_cam_t = Eigen::Vector3d::Zero();
  GrayImage image;
  std::string name;
  /// Pixels of the frame's image spanned by one pixel of this view (at the view's centre):
  /// 1 for the image itself, f_image / f_view for a perspective cut or cube face (< 1 when
  /// the cut upsamples the panorama), doubled per pyramid level. Acceptance tolerances
  /// (restart spread, predicted σ) are in the image's own pixels, not the cut's.
  double image_pixels_per_pixel = 1.0;
  /// The camera of the frame's own image when this view was cut from it (a panorama's
  /// perspective cuts and cube faces); unset when the view is the image itself. The
  /// acceptance then also measures the pose's accuracy over the whole image, whose pose it is,
  /// not only over the cuts registered.
  std::optional<sensors::Camera> image_camera;
};

/// A view's pose of the LiDAR frame, view_from_lidar = [view_from_cam | view_from_cam_t] ·
/// cam_from_lidar, in float as the renderer, the cull and the point samples use it.
struct ViewTransform {
  Eigen::Matrix3f rotation;
  Eigen::Vector3f translation;
};
inline ViewTransform MakeTransform(const View& view, const Rigid3d& cam_from_lidar) {
  ViewTransform t;
  t.rotation = (view.view_from_cam * cam_from_lidar.rotation.toRotationMatrix()).cast<float>();
  t.translation =
      (view.view_from_cam * cam_from_lidar.translation + view.view_from_cam_t).cast<float>();
  return t;
}

struct RenderOptions;

/// How the views of a frame are cut from its image.
enum class ViewKind {
  kImage,        ///< the image itself with its camera (pinhole, fisheye, or whole equirect)
  kPerspective,  ///< perspective cuts of an equirectangular panorama (paper: 940×452)
  kCube,         ///< the four side faces (90° each) of a cube map of the panorama
};
std::string ViewKindName(ViewKind kind);
/// "image"|"equirect" → kImage, "perspective", "cube"; false when unknown.
bool ParseViewKind(const std::string& name, ViewKind* kind);

struct ViewOptions {
  ViewKind kind = ViewKind::kImage;
  int perspective_width = 940;   ///< paper's view size
  int perspective_height = 452;
  double perspective_hfov_deg = 90.0;
  /// Headings of the perspective cuts relative to the panorama's centre column, degrees
  /// (the paper used views perpendicular to the driving direction: ±90).
  std::vector<double> perspective_yaw_deg = {-90.0, 90.0};
  int cube_face_size = 512;
  bool Check(std::string* error) const;
};

/// Cuts the views of one frame from its image and camera. Perspective and cube views need an
/// EQUIRECTANGULAR camera (InputError otherwise, naming `source`).
std::vector<View> MakeViews(const GrayImage& image, const sensors::Camera& camera,
                            const ViewOptions& options, const std::string& source);

/// A rig camera's image as a view of the rig's pose (rig_from_lidar): the image through its
/// own camera, p_view = cam_from_rig · p_rig, so that one registration corrects the rig's
/// pose from all its cameras, without a stitched panorama and its parallax. InputError naming
/// `source` when the image's size is not the camera's.
View MakeRigCameraView(const GrayImage& image, const sensors::Camera& camera,
                       const Rigid3d& cam_from_rig, const std::string& source);

/// How many points (counting stops at `limit`) lie in front of the view, within the render's
/// range and inside its image at `cam_from_lidar`, without an occlusion test: whether a view
/// sees the cloud at all.
size_t CountPointsInView(const LidarPoints& points, const View& view,
                         const Rigid3d& cam_from_lidar, const RenderOptions& render,
                         size_t limit);

/// Headings (degrees right of the panorama's centre column) for `count` perspective cuts that
/// see the most LiDAR: `candidates` headings evenly spaced round the panorama, each scored by
/// the fraction of its cut (options' size and field of view, rendered at a quarter of the
/// resolution) covered by the cloud at `cam_from_lidar`; the best first, then the next best
/// at least one field of view from those chosen. The paper's ±90° assumes the panorama's
/// centre is the driving direction and the buildings are at the sides; a static station or a
/// vehicle turning may face them anywhere. Needs an EQUIRECTANGULAR camera.
std::vector<double> SelectPerspectiveHeadings(const LidarPoints& points,
                                              const sensors::Camera& panorama_camera,
                                              const Rigid3d& cam_from_lidar,
                                              const ViewOptions& options,
                                              const RenderOptions& render, int count,
                                              int candidates = 8);

/// Half-resolution copy of a view (image box-filtered, camera focal/principal halved).
View DownsampleView(const View& view);

struct RenderOptions {
  Representation representation = Representation::kIntensity;
  /// Footprint of a point: radius = point_radius_m · f / range pixels, clamped to
  /// [0, max_point_radius_px] (0 = one pixel). Larger near the camera, as a real surface.
  double point_radius_m = 0.03;
  int max_point_radius_px = 2;
  double min_range_m = 0.5;    ///< points closer than this are ignored
  double max_range_m = 200.0;  ///< and farther
  bool Check(std::string* error) const;
};

/// A rendered LiDAR image: value in [0, 1] where covered, negative where no point is seen.
/// `offset_x/y` hold the sub-pixel position of the winning point relative to the pixel centre,
/// so that metrics can sample the photo where the point really falls (smooth in the pose).
struct LidarImage {
  int width = 0;
  int height = 0;
  std::vector<float> value;
  std::vector<float> depth;
  std::vector<float> offset_x;
  std::vector<float> offset_y;
  std::vector<int> point_index;  ///< winning point, -1 where empty
  size_t covered_pixels = 0;
  /// Scratch reused between renders: per pixel the packed (range bits, point index) key of
  /// the nearest point, and per point its projection (kept to avoid reallocation).
  std::vector<uint64_t> zbuffer;
  std::vector<Eigen::Vector2f> projected;
  std::vector<uint64_t> zbuffer_second;  ///< the second thread's z-buffer (two_threads)
};

/// The z-buffer key of a pixel no point covers (`LidarImage::zbuffer`).
constexpr uint64_t kEmptyZBufferKey = ~uint64_t{0};
/// Entries after the last pixel of `LidarImage::zbuffer`: a footprint row is written as a
/// fixed-width window that may run past the row's end, with the empty key there (a pixel
/// keeps its key).
constexpr size_t kZBufferPadding = 8;

/// The value of a covered pixel for the representation: intensity, 1 (points only), or the
/// depth map's log-range stretched over [min_range_m, max_range_m] (near bright). Shared by
/// RenderLidarImage and the histogram that reads the z-buffer directly, so that both give
/// the same numbers bit for bit.
class LidarValueMap {
 public:
  explicit LidarValueMap(const RenderOptions& options);
  /// Point `index`, seen at `range` (the z-buffer's float).
  [[gnu::always_inline]] float operator()(const LidarPoints& points, uint32_t index,
                                          float range) const;
  Representation representation() const { return representation_; }

 private:
  Representation representation_;
  float log_min_;
  float inv_log_span_;
};

/// Distinct points winning at least one pixel (the independent samples of the image).
size_t CountVisiblePoints(const LidarImage& image);

/// Renders the points seen by `view` from `cam_from_lidar` (the pose of the frame's image
/// camera). Depth values are 1/range stretched over [1/max_range, 1/min_range] (near bright).
/// For kIntensity the cloud must have intensity (CHECK; callers validate first).
/// `two_threads`: the points' footprints are drawn by two threads into two z-buffers that
/// are then merged by the same minimum (each pixel's nearest point, ties by rank): the image
/// is identical to the one-thread render, bit for bit.
void RenderLidarImage(const LidarPoints& points, const View& view, const Rigid3d& cam_from_lidar,
                      const RenderOptions& options, LidarImage* out, bool two_threads = false);

/// Pass 1 of RenderLidarImage alone: sets width and height and fills `out->zbuffer` (per
/// pixel (range bits << 32 | tie rank) of the nearest point, kEmptyZBufferKey where none;
/// width·height entries + kZBufferPadding) and `out->projected` (per point that lands in the
/// view), but NOT value, depth, offset_x/y, point_index, covered_pixels (left stale). For a
/// caller that reads the winners from the z-buffer (JointHistogram::AddZBuffer): it saves
/// writing and re-reading five arrays per pixel. `two_threads` as RenderLidarImage.
void RenderLidarZBuffer(const LidarPoints& points, const View& view,
                        const Rigid3d& cam_from_lidar, const RenderOptions& options,
                        LidarImage* out, bool two_threads = false);

/// The index of the point whose key won a pixel (the key's low 32 bits are its tie rank).
[[gnu::always_inline]] inline uint32_t ZBufferPointIndex(const LidarPoints& points,
                                                         uint64_t key) {
  const uint32_t low = static_cast<uint32_t>(key & 0xffffffffu);
  return points.tie_rank.empty() ? low : points.index_of_rank[low];
}

/// The range in metres of the point whose key won a pixel (the key's high 32 bits).
[[gnu::always_inline]] inline float ZBufferRange(uint64_t key) {
  const uint32_t bits = static_cast<uint32_t>(key >> 32);
  float range;
  std::memcpy(&range, &bits, sizeof(range));
  return range;
}

[[gnu::always_inline]] inline float LidarValueMap::operator()(const LidarPoints& points,
                                                              uint32_t index,
                                                              float range) const {
  if (representation_ == Representation::kIntensity) return points.intensity01[index];
  if (representation_ == Representation::kDepth) {
    return std::clamp(1.f - (std::log(range) - log_min_) * inv_log_span_, 0.f, 1.f);
  }
  return 1.f;
}

/// The LiDAR image as an 8-bit grey picture (empty pixels black), for reports and tests.
GrayImage LidarImageToGray(const LidarImage& image);

/// A PNG for the eye (register-mi --overlay): one panel per LiDAR image, stacked top to
/// bottom, each the photo in grey with the pixels that LiDAR image covers coloured by range
/// (jet over log range between the 2nd and 98th percentile of all panels' covered pixels:
/// near red, far blue), 70 % over the photo, and its label in the top-left corner. Every
/// LiDAR image must have the photo's size (std::invalid_argument otherwise).
std::vector<uint8_t> EncodeRangeOverlayPng(const GrayImage& photo,
                                           const std::vector<const LidarImage*>& panels,
                                           const std::vector<std::string>& labels);

}  // namespace mmba::registration::mi
