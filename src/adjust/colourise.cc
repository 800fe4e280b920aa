// LiDAR clouds coloured from the adjusted images (georeferenced point clouds, coloured from
// the images where seen): the static LiDAR around the photo block
// (lidar_coloured.ply, from the photos and the rig frames near it) and the whole mobile cloud
// (<id>_corrected.ply, streamed, from the rig frames nearest in time and the photos). The only
// other OpenCV translation unit of mmba_adjust besides sphere_dense.cc (it reads colour images).
//
// Both use one visibility test: a coarse z-buffer per image built from the cloud itself (the
// range of the nearest point per cell of a few pixels), a point is coloured by an image only
// when it is not behind that first surface; the colours of the images that see a point are
// averaged with the weight (f / r)² — the squared pixels per metre on the surface, i.e.
// 1 / r² (nearer views see more detail) scaled by the camera's focal length f so that a
// fisheye and a photo of the same point count by their resolution.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <limits>
#include <list>
#include <map>
#include <mutex>

#include <spdlog/spdlog.h>

#include "codecs/image_codecs.h"
#include "internal.h"
#include "las_output.h"
#include "mmba/core/parallel_for.h"

namespace mmba::adjust::internal {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

/// Memory for the z-buffers of all the images that colour the mobile cloud (they live from the
/// first pass to the second): their cell grows so that they fit.
constexpr size_t kDepthBudgetBytes = size_t{256} << 20;
/// Rig frames per side of a mobile point's time that may colour it: the 2 before and 2 after.
constexpr size_t kFramesPerSide = 2;
/// Static LiDAR: rig frames whose centre is within this of the photo block's box colour it too.
constexpr double kStaticRigReachM = 20.0;
constexpr uint8_t kGrey = 128;  ///< points no image sees

/// A coarse z-buffer of one image: per cell of `cell` × `cell` pixels the range of the nearest
/// cloud point projected into it.
class DepthGrid {
 public:
  DepthGrid() = default;
  DepthGrid(int width, int height, int cell)
      : cell_(cell), gw_((width + cell - 1) / cell), gh_((height + cell - 1) / cell),
        depth_(static_cast<size_t>(gw_) * gh_, std::numeric_limits<float>::infinity()) {}

  void Add(int u, int v, float range) {
    float& d = depth_[Index(u / cell_, v / cell_)];
    d = std::min(d, range);
  }

  /// Whether a point at pixel (u, v) and `range` is on the first surface of its cell: not
  /// behind it by more than 2 % + 5 cm plus the depth change of that surface across one cell
  /// (on each axis the smaller of the differences to the two neighbouring cells: a slope goes
  /// on on both sides, an occluding edge on one only) — so the road seen at grazing incidence,
  /// whose range grows by decimetres within a cell, is not hidden by its own near edge, and the
  /// wall behind a pole is.
  bool Visible(int u, int v, float range) const {
    const int cu = u / cell_, cv = v / cell_;
    const float front = depth_[Index(cu, cv)];
    const auto at = [&](int x, int y) {
      return x < 0 || y < 0 || x >= gw_ || y >= gh_ ? std::numeric_limits<float>::infinity() : depth_[Index(x, y)];
    };
    const auto slope = [&](float a, float b) {
      const float s = std::min(std::abs(a - front), std::abs(b - front));
      return std::isfinite(s) ? s : 0.0f;
    };
    const float tolerance = 0.02f * front + 0.05f + slope(at(cu - 1, cv), at(cu + 1, cv)) + slope(at(cu, cv - 1), at(cu, cv + 1));
    return range <= front + tolerance;
  }

  size_t bytes() const { return depth_.size() * sizeof(float); }

 private:
  size_t Index(int x, int y) const { return static_cast<size_t>(y) * gw_ + x; }
  int cell_ = 1, gw_ = 0, gh_ = 0;
  std::vector<float> depth_;
};

/// One image that colours a cloud.
struct ColourView {
  std::string name;  ///< for the report
  std::string path;
  const sensors::Camera* camera = nullptr;
  Eigen::Matrix3d rotation;     ///< cam_from_world
  Eigen::Vector3d translation;
  double weight_scale = 1.0;    ///< f², for the (f / r)² weight
  DepthGrid depth;
  size_t samples = 0;           ///< points it coloured

  ColourView(std::string n, std::string p, const sensors::Camera& c, const Rigid3d& cam_from_world)
      : name(std::move(n)), path(std::move(p)), camera(&c), rotation(cam_from_world.rotation.toRotationMatrix()),
        translation(cam_from_world.translation) {
    const double f = c.MeanFocalLength();
    weight_scale = f * f;
  }

  Eigen::Vector3d Centre() const { return -rotation.transpose() * translation; }

  /// Pixel and range of a world point; false when it is behind the camera, outside the
  /// model's domain or outside the image.
  bool Project(const Eigen::Vector3d& world, int* u, int* v, float* range) const {
    const Eigen::Vector3d pc = rotation * world + translation;
    if (pc.z() <= 0.1) return false;
    const std::optional<Eigen::Vector2d> uv = camera->ImgFromCam(pc);
    if (!uv) return false;
    *u = static_cast<int>(std::floor(uv->x()));
    *v = static_cast<int>(std::floor(uv->y()));
    if (*u < 0 || *v < 0 || *u >= static_cast<int>(camera->width) || *v >= static_cast<int>(camera->height)) return false;
    *range = static_cast<float>(pc.norm());
    return true;
  }

  /// The z-buffer with cells of `cell` pixels (empty).
  void ResetDepth(int cell) { depth = DepthGrid(static_cast<int>(camera->width), static_cast<int>(camera->height), cell); }

  /// Enters `points[i]` for i in `subset` (all when null) into the z-buffer.
  void AddDepths(const std::vector<Eigen::Vector3d>& points, const std::vector<uint32_t>* subset) {
    const size_t n = subset ? subset->size() : points.size();
    for (size_t j = 0; j < n; ++j) {
      int u, v;
      float r;
      if (Project(points[subset ? (*subset)[j] : j], &u, &v, &r)) depth.Add(u, v, r);
    }
  }

  /// Adds the colour of the image at `points[i]` (i = subset[j] for j in [begin, end), i = j
  /// when `subset` is null) with its weight to `sum` / `weight` where the point is visible;
  /// `seen[i] |= flag` for those. Returns their number. Threads may share a view and the
  /// accumulators as long as their j ranges hold different points.
  size_t AddColours(const cv::Mat& image, const std::vector<Eigen::Vector3d>& points, const std::vector<uint32_t>* subset,
                    size_t begin, size_t end, std::vector<Eigen::Vector3f>* sum, std::vector<float>* weight,
                    std::vector<uint8_t>* seen, uint8_t flag) const {
    size_t added = 0;
    for (size_t j = begin; j < end; ++j) {
      const size_t i = subset ? (*subset)[j] : j;
      int u, v;
      float r;
      if (!Project(points[i], &u, &v, &r) || !depth.Visible(u, v, r)) continue;
      if (u >= image.cols || v >= image.rows) continue;  // an image smaller than its camera says
      Eigen::Vector3f rgb;
      if (image.channels() == 1) {
        rgb.setConstant(image.at<uint8_t>(v, u));
      } else {
        const cv::Vec3b c = image.at<cv::Vec3b>(v, u);
        rgb = Eigen::Vector3f(c[2], c[1], c[0]);
      }
      const float w = static_cast<float>(weight_scale) / (r * r);
      (*sum)[i] += w * rgb;
      (*weight)[i] += w;
      (*seen)[i] |= flag;
      ++added;
    }
    return added;
  }
};

/// Grey images stay one channel (a third of the memory), colour ones are BGR; 16-bit ones are
/// reduced to 8 bits. Empty when unreadable.
cv::Mat ReadImage(const std::string& path) {
  return codecs::ReadImage(path, cv::IMREAD_ANYCOLOR);
}

/// The averaged colours (grey where no image saw the point).
void FinishColours(const std::vector<Eigen::Vector3f>& sum, const std::vector<float>& weight,
                   std::vector<std::array<uint8_t, 3>>* colours, size_t* coloured) {
  colours->resize(sum.size());
  for (size_t i = 0; i < sum.size(); ++i) {
    if (weight[i] > 0) {
      const Eigen::Vector3f c = sum[i] / weight[i];
      (*colours)[i] = {static_cast<uint8_t>(std::lround(c.x())), static_cast<uint8_t>(std::lround(c.y())),
                       static_cast<uint8_t>(std::lround(c.z()))};
      ++*coloured;
    } else {
      (*colours)[i] = {kGrey, kGrey, kGrey};
    }
  }
}

/// Cell size of a z-buffer of `camera`'s images: ~1/400 of the width, at least 2 px (the static
/// LiDAR: one z-buffer at a time).
int DepthCell(const sensors::Camera& camera) { return std::max(2, static_cast<int>(camera.width / 400)); }

/// Cell size when the z-buffers of all `views` are held at once: as DepthCell, larger when they
/// would exceed kDepthBudgetBytes.
int DepthCell(const std::vector<ColourView>& views) {
  int cell = 2;
  double pixels = 0.0;
  for (const ColourView& v : views) {
    cell = std::max(cell, DepthCell(*v.camera));
    pixels += static_cast<double>(v.camera->width) * v.camera->height;
  }
  return std::max(cell, static_cast<int>(std::ceil(std::sqrt(pixels * sizeof(float) / kDepthBudgetBytes))));
}

/// The photo block's box (its tie points, 1 m around); false without photos.
bool PhotoBox(const JointState& s, Eigen::Vector3d* lo, Eigen::Vector3d* hi) {
  if (!s.photos) return false;
  *lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  *hi = -*lo;
  for (const auto& [id, p] : s.scene.points()) {
    if (id.value >= kCheckPointIdBase) continue;
    *lo = lo->cwiseMin(p);
    *hi = hi->cwiseMax(p);
  }
  if (!(lo->array() <= hi->array()).all()) return false;
  lo->array() -= 1.0;
  hi->array() += 1.0;
  return true;
}

bool InBox(const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  return (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all();
}

/// The photos as views (adjusted poses and intrinsics).
std::vector<ColourView> PhotoViews(const JointState& s) {
  std::vector<ColourView> views;
  if (!s.photos) return views;
  for (const auto& [id, image] : s.photos->model.images) {
    views.emplace_back(image.name, (fs::path(s.photos->config->images) / image.name).string(),
                       s.scene.Camera(image.camera_id), s.scene.Image(id).cam_from_world);
  }
  return views;
}

/// The rig's images of `frame` as views, in camera order; a camera whose image is missing
/// has an empty path.
std::vector<ColourView> RigFrameViews(const JointState& s, size_t frame, const std::map<std::string, std::string>& files) {
  const RigBlock& rig = *s.rig;
  std::vector<ColourView> views;
  for (size_t k = 0; k < rig.cameras.size(); ++k) {
    const std::string stem = rig.frame_names[frame] + "_" + rig.camera_names[k];
    const auto it = files.find(stem);
    views.emplace_back(stem, it == files.end() ? std::string() : it->second, s.scene.Camera(rig.cameras[k]),
                       s.scene.CamFromRig(rig.cameras[k]) * s.scene.RigFrame(FrameId(frame)));
  }
  return views;
}

/// The image files of a folder by stem.
std::map<std::string, std::string> FilesByStem(const std::string& folder) {
  std::map<std::string, std::string> files;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    if (entry.is_regular_file()) files.emplace(entry.path().stem().string(), entry.path().string());
  }
  return files;
}

/// The LiDAR points in the box, in the world frame (adjusted scans, else the reference cloud),
/// thinned evenly to at most `cap`.
io::PointCloud LidarInBox(const JointState& s, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, size_t cap) {
  io::PointCloud out;
  const auto read = [&](const std::string& path, const Rigid3d& world_from_file) {
    io::StreamPointCloud(path, kMobileChunkPoints, [&](const io::PointCloud& chunk, size_t, size_t) {
      for (const Eigen::Vector3d& p : chunk.points) {
        const Eigen::Vector3d w = world_from_file * p;
        if (InBox(w, lo, hi)) out.points.push_back(w);
      }
    });
  };
  if (!s.scans.empty()) {
    for (size_t k = 0; k < s.scans.size(); ++k) read(s.scans[k].file, s.scene.Scan(ScanId(k)).Inverse());
  } else {
    read(s.project->lidar_static.front().reference_cloud, Rigid3d());
  }
  ThinEvenly(&out.points, cap);
  return out;
}

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

/// CPU time of the process [s] (all its threads: while the outputs are written only the
/// colouring's run; wall times are inflated by whatever else the machine runs).
double CpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

/// Threads worth starting for `n` points (a thread per 20,000 at least).
int ThreadsFor(size_t n, int threads) { return static_cast<int>(std::clamp<size_t>(n / 20000, 1, std::max(1, threads))); }

}  // namespace

json WriteColouredLidar(const JointState& s, const fs::path& stage, json* files) {
  json entry;
  if (!s.photos || s.project->lidar_static.empty()) return entry;
  Eigen::Vector3d lo, hi;
  if (!PhotoBox(s, &lo, &hi)) return entry;
  constexpr size_t kMaxPoints = 5000000;
  io::PointCloud cloud = LidarInBox(s, lo, hi, kMaxPoints);
  const size_t n = cloud.size();
  // The photos, and the images of the rig frames within kStaticRigReachM of the box.
  std::vector<ColourView> views = PhotoViews(s);
  const size_t num_photos = views.size();
  if (s.rig) {
    const std::map<std::string, std::string> rig_files = FilesByStem(s.rig->config->images);
    for (size_t f = 0; f < s.rig->frame_names.size(); ++f) {
      const Eigen::Vector3d centre = s.scene.RigFrame(FrameId(f)).Inverse().translation;
      if ((centre - centre.cwiseMax(lo).cwiseMin(hi)).norm() > kStaticRigReachM) continue;
      for (ColourView& v : RigFrameViews(s, f, rig_files)) views.push_back(std::move(v));
    }
  }
  std::vector<Eigen::Vector3f> sum(n, Eigen::Vector3f::Zero());
  std::vector<float> weight(n, 0.0f);
  std::vector<uint8_t> seen(n, 0);
  size_t photos = 0, rig_images = 0;
  std::vector<std::string> unreadable;
  for (size_t k = 0; k < views.size(); ++k) {
    ColourView& view = views[k];
    const cv::Mat image = view.path.empty() ? cv::Mat() : ReadImage(view.path);
    if (image.empty()) {
      unreadable.push_back(view.path.empty() ? view.name + " (no file)" : view.path);
      continue;
    }
    // One image at a time: its z-buffer of the whole cloud, then its colours.
    view.ResetDepth(DepthCell(*view.camera));
    view.AddDepths(cloud.points, nullptr);
    view.samples += view.AddColours(image, cloud.points, nullptr, 0, n, &sum, &weight, &seen, k < num_photos ? 1 : 2);
    view.depth = DepthGrid();
    ++(k < num_photos ? photos : rig_images);
  }
  size_t coloured = 0, from_rig = 0;
  FinishColours(sum, weight, &cloud.colors, &coloured);
  for (uint8_t b : seen) from_rig += (b & 2) ? 1 : 0;
  io::WritePly(cloud, (stage / "lidar_coloured.ply").string());
  WriteLasBeside(s, cloud, stage / "lidar_coloured.ply");
  files->push_back({{"name", "lidar_coloured.ply"},
                    {"description", "the static LiDAR around the photo block (adjusted scans, else the reference "
                                    "cloud), coloured from the adjusted photos and the rig images near it where seen "
                                    "(grey: not seen)"}});
  files->push_back(LasFileEntry(s, "lidar_coloured.ply", "the coloured static LiDAR"));
  entry = {{"file", "lidar_coloured.ply"}, {"points", n}, {"coloured", coloured}, {"images", photos + rig_images},
           {"photos", photos}, {"rig_images", rig_images}, {"coloured_by_rig_images", from_rig},
           {"unreadable_images", unreadable}};
  spdlog::info("adjust: LiDAR coloured from {} photos and {} rig images: {} of {} points seen", photos, rig_images,
               coloured, n);
  return entry;
}

// ---- the mobile cloud ----

struct MobileColouring::Impl {
  std::vector<ColourView> views;    ///< frame f (in time order) camera k at f * cameras + k, then the photos
  size_t cameras = 0;
  std::vector<double> frame_time;   ///< rig frames sorted by time
  size_t first_photo = 0;
  bool has_box = false;
  Eigen::Vector3d lo, hi;           ///< photo block's box
  // Rig images of the last frames used (the cloud usually comes in time order).
  std::list<std::pair<size_t, std::vector<cv::Mat>>> cache;
  size_t cache_frames = 2 * kFramesPerSide + 1;
  std::vector<bool> unreadable;     ///< per view
  // Counts.
  size_t points = 0, coloured = 0, by_rig = 0, by_photos = 0, image_loads = 0;
  int threads = 1;
  double depth_cpu = 0.0, colour_cpu = 0.0;  ///< process CPU seconds in AddDepths / Colour
  double colour_wall = 0.0;                  ///< wall seconds in Colour
  /// The first pass, from construction to the first Colour call (the stream's reading and
  /// georeferencing included): what the colouring adds besides colour_cpu. Wall and CPU.
  std::chrono::steady_clock::time_point created = std::chrono::steady_clock::now();
  double created_cpu = CpuSeconds();
  double first_pass_seconds = -1.0, first_pass_cpu = -1.0;
  int cell = 2;

  /// The window [*begin, *end) of sorted frames around `time`.
  void Window(double time, size_t* begin, size_t* end) const {
    const size_t i = std::upper_bound(frame_time.begin(), frame_time.end(), time) - frame_time.begin();
    *begin = i >= kFramesPerSide ? i - kFramesPerSide : 0;
    *end = std::min(frame_time.size(), i + kFramesPerSide);
  }

  /// Per sorted frame, the indices of the chunk's points whose window holds it.
  std::vector<std::vector<uint32_t>> PointsByFrame(const io::PointCloud& chunk) const {
    std::vector<std::vector<uint32_t>> by_frame(frame_time.size());
    for (size_t i = 0; i < chunk.size(); ++i) {
      size_t b, e;
      Window(chunk.time[i], &b, &e);
      for (size_t f = b; f < e; ++f) by_frame[f].push_back(static_cast<uint32_t>(i));
    }
    return by_frame;
  }

  std::vector<uint32_t> InPhotoBox(const io::PointCloud& chunk) const {
    std::vector<uint32_t> in;
    if (!has_box) return in;
    for (size_t i = 0; i < chunk.size(); ++i) {
      if (InBox(chunk.points[i], lo, hi)) in.push_back(static_cast<uint32_t>(i));
    }
    return in;
  }

  const std::vector<cv::Mat>& FrameImages(size_t f) {
    for (auto it = cache.begin(); it != cache.end(); ++it) {
      if (it->first == f) {
        cache.splice(cache.begin(), cache, it);
        return cache.front().second;
      }
    }
    std::vector<cv::Mat> images(cameras);
    for (size_t k = 0; k < cameras; ++k) {
      const size_t v = f * cameras + k;
      if (unreadable[v]) continue;
      images[k] = ReadImage(views[v].path);
      ++image_loads;
      if (images[k].empty()) unreadable[v] = true;
    }
    cache.emplace_front(f, std::move(images));
    if (cache.size() > cache_frames) cache.pop_back();
    return cache.front().second;
  }
};

MobileColouring::MobileColouring(const JointState& s, int threads) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.threads = std::max(1, threads);
  // The rig's frames on the same vehicle (their times are the LiDAR's clock), in time order.
  if (s.rig && s.mobile && s.mobile->with_rig) {
    const RigBlock& rig = *s.rig;
    const std::map<std::string, std::string> files = FilesByStem(rig.config->images);
    std::vector<size_t> order(rig.frame_times.size());
    for (size_t f = 0; f < order.size(); ++f) order[f] = f;
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return rig.frame_times[a] < rig.frame_times[b]; });
    m.cameras = rig.cameras.size();
    for (size_t f : order) {
      m.frame_time.push_back(rig.frame_times[f]);
      for (ColourView& v : RigFrameViews(s, f, files)) m.views.push_back(std::move(v));
    }
  }
  m.first_photo = m.views.size();
  m.has_box = PhotoBox(s, &m.lo, &m.hi);
  if (m.has_box) {
    for (ColourView& v : PhotoViews(s)) m.views.push_back(std::move(v));
  }
  m.unreadable.assign(m.views.size(), false);
  for (size_t v = 0; v < m.views.size(); ++v) m.unreadable[v] = m.views[v].path.empty();
  if (m.views.empty()) return;
  // Every z-buffer is held from the first pass to the second: within kDepthBudgetBytes.
  m.cell = DepthCell(m.views);
  for (ColourView& v : m.views) v.ResetDepth(m.cell);
}

MobileColouring::~MobileColouring() = default;

bool MobileColouring::active() const { return !impl_->views.empty(); }

void MobileColouring::AddDepths(const io::PointCloud& chunk) {
  Impl& m = *impl_;
  if (m.views.empty()) return;
  const double start = CpuSeconds();
  const std::vector<std::vector<uint32_t>> by_frame = m.PointsByFrame(chunk);
  const std::vector<uint32_t> in_box = m.InPhotoBox(chunk);
  // One z-buffer per task: the threads take every threads-th.
  std::vector<std::pair<size_t, const std::vector<uint32_t>*>> tasks;
  for (size_t f = 0; f < by_frame.size(); ++f) {
    if (by_frame[f].empty()) continue;
    for (size_t k = 0; k < m.cameras; ++k) tasks.push_back({f * m.cameras + k, &by_frame[f]});
  }
  if (!in_box.empty()) {
    for (size_t v = m.first_photo; v < m.views.size(); ++v) tasks.push_back({v, &in_box});
  }
  OnThreads(ThreadsFor(chunk.size(), m.threads), [&](int t, int threads) {
    for (size_t i = t; i < tasks.size(); i += threads) m.views[tasks[i].first].AddDepths(chunk.points, tasks[i].second);
  });
  m.depth_cpu += CpuSeconds() - start;
}

void MobileColouring::Colour(io::PointCloud* chunk) {
  Impl& m = *impl_;
  if (m.views.empty()) return;
  const double start = CpuSeconds();
  const auto start_wall = std::chrono::steady_clock::now();
  if (m.first_pass_seconds < 0) {
    m.first_pass_seconds = Seconds(m.created);
    m.first_pass_cpu = start - m.created_cpu;
  }
  const size_t n = chunk->size();
  std::vector<Eigen::Vector3f> sum(n, Eigen::Vector3f::Zero());
  std::vector<float> weight(n, 0.0f);
  std::vector<uint8_t> seen(n, 0);
  const std::vector<std::vector<uint32_t>> by_frame = m.PointsByFrame(*chunk);
  for (size_t f = 0; f < by_frame.size(); ++f) {
    if (by_frame[f].empty()) continue;
    const std::vector<cv::Mat>& images = m.FrameImages(f);
    std::vector<size_t> added(m.cameras, 0);
    std::mutex mutex;
    // The threads split the frame's points (each point's accumulator has one writer).
    const size_t np = by_frame[f].size();
    OnThreads(ThreadsFor(np, m.threads), [&](int t, int threads) {
      for (size_t k = 0; k < m.cameras; ++k) {
        if (images[k].empty()) continue;
        const size_t a = m.views[f * m.cameras + k].AddColours(images[k], chunk->points, &by_frame[f], np * t / threads,
                                                               np * (t + 1) / threads, &sum, &weight, &seen, 1);
        std::lock_guard<std::mutex> lock(mutex);
        added[k] += a;
      }
    });
    for (size_t k = 0; k < m.cameras; ++k) m.views[f * m.cameras + k].samples += added[k];
  }
  // The photos, one at a time, for the points in the photo block's box.
  const std::vector<uint32_t> in_box = m.InPhotoBox(*chunk);
  if (!in_box.empty()) {
    for (size_t v = m.first_photo; v < m.views.size(); ++v) {
      if (m.unreadable[v]) continue;
      const cv::Mat image = ReadImage(m.views[v].path);
      ++m.image_loads;
      if (image.empty()) {
        m.unreadable[v] = true;
        continue;
      }
      std::mutex mutex;
      OnThreads(ThreadsFor(in_box.size(), m.threads), [&](int t, int threads) {
        const size_t a = m.views[v].AddColours(image, chunk->points, &in_box, in_box.size() * t / threads,
                                               in_box.size() * (t + 1) / threads, &sum, &weight, &seen, 2);
        std::lock_guard<std::mutex> lock(mutex);
        m.views[v].samples += a;
      });
    }
  }
  FinishColours(sum, weight, &chunk->colors, &m.coloured);
  for (uint8_t b : seen) {
    m.by_rig += (b & 1) ? 1 : 0;
    m.by_photos += (b & 2) ? 1 : 0;
  }
  m.points += n;
  m.colour_cpu += CpuSeconds() - start;
  m.colour_wall += Seconds(start_wall);
}

json MobileColouring::Report(const std::string& file) const {
  const Impl& m = *impl_;
  size_t rig_images = 0, photos = 0, rig_available = 0;
  std::vector<std::string> unreadable;
  for (size_t v = 0; v < m.views.size(); ++v) {
    const bool photo = v >= m.first_photo;
    if (m.unreadable[v]) {
      unreadable.push_back(m.views[v].path.empty() ? m.views[v].name + " (no file)" : m.views[v].path);
    } else if (!photo) {
      ++rig_available;
    }
    if (m.views[v].samples > 0) ++(photo ? photos : rig_images);
  }
  size_t depth_bytes = 0;
  for (const ColourView& v : m.views) depth_bytes += v.depth.bytes();
  spdlog::info("adjust: mobile cloud coloured from {} rig images and {} photos: {} of {} points seen (first pass {:.1f} s "
               "wall, {:.1f} s CPU; colours {:.1f} s wall, {:.1f} s CPU)", rig_images, photos, m.coloured, m.points,
               m.first_pass_seconds, m.first_pass_cpu, m.colour_wall, m.colour_cpu);
  return {{"file", file}, {"points", m.points}, {"coloured", m.coloured}, {"coloured_by_rig_images", m.by_rig},
          {"coloured_by_photos", m.by_photos}, {"images", rig_images + photos}, {"rig_images", rig_images},
          {"rig_images_available", rig_available}, {"photos", photos}, {"frames_per_side", kFramesPerSide},
          {"depth_cell_px", m.cell}, {"depth_buffer_mb", depth_bytes / 1048576.0}, {"image_reads", m.image_loads},
          {"first_pass_seconds", m.first_pass_seconds}, {"first_pass_cpu_seconds", m.first_pass_cpu},
          {"depth_cpu_seconds", m.depth_cpu}, {"colour_cpu_seconds", m.colour_cpu}, {"colour_seconds", m.colour_wall},
          {"threads", m.threads},
          {"unreadable_images", unreadable}};
}

}  // namespace mmba::adjust::internal
