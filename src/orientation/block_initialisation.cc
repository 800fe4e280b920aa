#include "mmba/orientation/block_initialisation.h"

#include <algorithm>
#include <set>

#include <Eigen/Geometry>

#include "mmba/orientation/intersection.h"
#include "mmba/orientation/relative_orientation.h"

namespace mmba::orientation {
namespace {

using Obs = std::pair<std::string, Eigen::Vector2d>;  // (other id, pixel)

/// The growing block: observations by image and by point, and what is known so far.
class Block {
 public:
  Block(const BlockInput& in, const BlockOptions& options, BlockResult* out) : in_(in), options_(options), out_(*out) {
    for (const BlockMeasurement& m : in.measurements) {
      by_image_[m.image_id].push_back({m.point_id, m.xy_px});
      by_point_[m.point_id].push_back({m.image_id, m.xy_px});
    }
  }

  /// Seeds by resection from the control: the images that see min_inliers control points or
  /// more, the one seeing the most first, until one is oriented.
  bool SeedFromControl() {
    std::vector<std::pair<size_t, std::string>> candidates;  // (control points seen, image)
    for (const std::string& image : in_.images) {
      size_t n = 0;
      for (const Obs& o : by_image_[image]) n += in_.control.count(o.first);
      if (static_cast<int>(n) >= options_.resection.min_inliers) candidates.push_back({n, image});
    }
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    out_.points = in_.control;
    out_.frame = "control";
    for (const auto& [n, image] : candidates) {
      if (Orient(image)) return true;
    }
    return false;
  }

  bool SeedFromPrior() {
    if (in_.prior_cam_from_world.empty()) return false;
    for (const auto& [image, pose] : in_.prior_cam_from_world) {
      if (!by_image_.count(image)) continue;
      out_.cam_from_world[image] = pose;
      out_.log.push_back("image " + image + ": prior EO");
    }
    for (const auto& [point, xyz] : in_.control) out_.points[point] = xyz;
    out_.frame = "prior EO";
    gate_px_ = options_.prior_max_error_px;  // approximate poses: the bundle refines them
    gate_deg_ = options_.prior_min_angle_deg;
    for (const auto& [point, obs] : by_point_) TryIntersect(point, GrowingRays(point));
    return true;
  }

  /// Relative orientation of the pair with the most common points that succeeds.
  bool SeedFromPair() {
    std::map<std::pair<std::string, std::string>, size_t> common;
    for (const auto& [point, obs] : by_point_) {
      for (size_t i = 0; i < obs.size(); ++i) {
        for (size_t j = i + 1; j < obs.size(); ++j) ++common[std::minmax(obs[i].first, obs[j].first)];
      }
    }
    std::vector<std::pair<size_t, std::pair<std::string, std::string>>> pairs;
    for (const auto& [pair, n] : common) pairs.push_back({n, pair});
    std::sort(pairs.rbegin(), pairs.rend());
    for (size_t k = 0; k < std::min<size_t>(pairs.size(), 10); ++k) {
      if (TryPair(pairs[k].second.first, pairs[k].second.second)) return true;
    }
    return false;
  }

  /// Orients the image seeing the most known points until none can be.
  void Grow() {
    while (true) {
      std::string best;
      size_t most = 0;
      for (const std::string& image : in_.images) {
        if (out_.cam_from_world.count(image) || out_.failed_images.count(image)) continue;
        const size_t n = KnownCount(image);
        if (n > most) most = n, best = image;
      }
      if (best.empty() || static_cast<int>(most) < options_.resection.min_inliers) {
        // Stuck: the points of two oriented rays (held back for a third while growing)
        // may give the remaining images their points.
        size_t added = 0;
        for (const auto& [point, obs] : by_point_) added += TryIntersect(point, 2);
        if (added == 0) return;
        continue;
      }
      Orient(best);
    }
  }

  /// Similarity of an arbitrary-frame block onto its intersected control points.
  void MoveOntoControl() {
    std::vector<Eigen::Vector3d> from, to;
    for (const auto& [id, xyz] : in_.control) {
      if (out_.points.count(id)) from.push_back(out_.points.at(id)), to.push_back(xyz);
    }
    if (from.size() < 3) {
      out_.frame = "relative orientation (arbitrary frame, unit base)";
      return;
    }
    Eigen::Matrix3Xd a(3, from.size()), b(3, from.size());
    for (size_t i = 0; i < from.size(); ++i) a.col(i) = from[i], b.col(i) = to[i];
    const Eigen::Matrix4d m = Eigen::umeyama(a, b, true);  // world_from_block
    const double s = m.topLeftCorner<3, 3>().col(0).norm();
    const Eigen::Matrix3d r = m.topLeftCorner<3, 3>() / s;
    const Eigen::Vector3d t = m.topRightCorner<3, 1>();
    for (auto& [id, xyz] : out_.points) xyz = s * r * xyz + t;
    for (auto& [id, pose] : out_.cam_from_world) {  // cam_from_world' = cam_from_block · block_from_world
      const Eigen::Vector3d centre = s * r * pose.TargetOriginInSource() + t;
      const Eigen::Quaterniond q = pose.rotation * Eigen::Quaterniond(r.transpose());
      pose = Rigid3d(q, -(q * centre));
    }
    for (const auto& [id, xyz] : in_.control) out_.points[id] = xyz;
    out_.frame = "relative orientation, similarity on " + std::to_string(from.size()) + " control points";
  }

  void ReportLeftovers() {
    for (const auto& [point, obs] : by_point_) TryIntersect(point, 2);  // the points of two rays
    for (const std::string& image : in_.images) {
      if (out_.cam_from_world.count(image) || out_.failed_images.count(image)) continue;
      out_.failed_images[image] = "too few points to orient: " + std::to_string(KnownCount(image)) +
                                  " of its points have coordinates, " + std::to_string(options_.resection.min_inliers) +
                                  " needed";
    }
    for (const auto& [point, obs] : by_point_) {
      if (out_.points.count(point) || out_.failed_points.count(point)) continue;
      size_t oriented = 0;
      for (const Obs& o : obs) oriented += out_.cam_from_world.count(o.first);
      out_.failed_points[point] = obs.size() < 2 ? "measured in one image only (image " + obs[0].first + ")"
                                  : oriented < 2 ? "measured in " + std::to_string(oriented) + " oriented image(s)"
                                                 : "its rays do not intersect within " + std::to_string(gate_px_) +
                                                       " px at " + std::to_string(gate_deg_) + " deg or more";
    }
  }

 private:
  size_t KnownCount(const std::string& image) {
    size_t n = 0;
    for (const Obs& o : by_image_[image]) n += out_.points.count(o.first) && !IsOutlier(image, o.first);
    return n;
  }
  bool IsOutlier(const std::string& image, const std::string& point) const { return outlier_.count({image, point}) > 0; }
  /// Rays a point needs while the block grows: 3, or all of them for a point measured twice.
  size_t GrowingRays(const std::string& point) { return std::min<size_t>(3, by_point_[point].size()); }

  bool Orient(const std::string& image) {
    std::vector<Eigen::Vector2d> xy;
    std::vector<Eigen::Vector3d> xyz;
    std::vector<std::string> ids;
    for (const Obs& o : by_image_[image]) {
      if (!out_.points.count(o.first) || IsOutlier(image, o.first)) continue;
      xy.push_back(o.second);
      xyz.push_back(out_.points.at(o.first));
      ids.push_back(o.first);
    }
    const ResectionResult r = Resect(*in_.camera, xy, xyz, options_.resection);
    if (!r.ok) {
      out_.failed_images[image] = "space resection failed: " + r.reason;
      out_.log.push_back("image " + image + ": " + out_.failed_images[image]);
      return false;
    }
    out_.cam_from_world[image] = r.cam_from_world;
    for (size_t i = 0; i < ids.size(); ++i) {
      if (r.inlier[i]) continue;
      outlier_.insert({image, ids[i]});
      out_.outliers.push_back({image, ids[i], ReprojectionErrorPx(*in_.camera, r.cam_from_world, xy[i], xyz[i]), "resection"});
    }
    out_.log.push_back("image " + image + ": space resection on " + std::to_string(r.num_inliers()) + " of " +
                       std::to_string(ids.size()) + " points, RMS " + std::to_string(r.rms_px) + " px");
    for (const Obs& o : by_image_[image]) TryIntersect(o.first, GrowingRays(o.first));
    return true;
  }

  /// Intersects `point` from its oriented rays when there are at least `min_rays` (3 while
  /// the block grows: a blunder along the epipolar line of a 2-ray point moves its depth
  /// without a residual; the point waits for a third ray or the final pass).
  bool TryIntersect(const std::string& point, size_t min_rays) {
    if (out_.points.count(point)) return false;
    std::vector<Ray> rays;
    std::vector<std::string> images;
    for (const Obs& o : by_point_[point]) {
      const auto it = out_.cam_from_world.find(o.first);
      if (it == out_.cam_from_world.end() || IsOutlier(o.first, point)) continue;
      rays.push_back({in_.camera, it->second, o.second});
      images.push_back(o.first);
    }
    if (rays.size() < std::max<size_t>(2, min_rays)) return false;
    IntersectionResult r = Intersect(rays, gate_deg_);
    if (r.ok && r.max_error_px > gate_px_ && rays.size() >= 3) {
      // One ray off: leave out the worst and intersect again (it is reported).
      size_t worst = 0;
      double e_max = 0;
      for (size_t i = 0; i < rays.size(); ++i) {
        const double e = ReprojectionErrorPx(*in_.camera, rays[i].cam_from_world, rays[i].xy_px, r.point_in_world);
        if (e > e_max) e_max = e, worst = i;
      }
      std::vector<Ray> kept = rays;
      kept.erase(kept.begin() + worst);
      const IntersectionResult again = Intersect(kept, gate_deg_);
      if (again.ok && again.max_error_px <= gate_px_) {
        outlier_.insert({images[worst], point});
        out_.outliers.push_back({images[worst], point,
                                 ReprojectionErrorPx(*in_.camera, rays[worst].cam_from_world, rays[worst].xy_px, again.point_in_world),
                                 "intersection"});
        r = again;
      }
    }
    if (!r.ok || r.max_error_px > gate_px_) return false;
    out_.points[point] = r.point_in_world;
    return true;
  }

  bool TryPair(const std::string& a, const std::string& b) {
    std::map<std::string, Eigen::Vector2d> in_a;
    for (const Obs& o : by_image_[a]) in_a[o.first] = o.second;
    std::vector<Eigen::Vector2d> xa, xb;
    for (const Obs& o : by_image_[b]) {
      if (in_a.count(o.first)) xa.push_back(in_a[o.first]), xb.push_back(o.second);
    }
    const RelativeOrientationResult r = RelativeOrientation(*in_.camera, *in_.camera, xa, xb, options_.relative_max_error_px);
    if (!r.ok) {
      out_.log.push_back("pair " + a + ", " + b + ": relative orientation failed: " + r.reason);
      return false;
    }
    out_.cam_from_world[a] = Rigid3d();
    out_.cam_from_world[b] = r.cam2_from_cam1;
    size_t n = 0;
    for (const Obs& o : by_image_[b]) n += TryIntersect(o.first, 2);
    if (n < 5) {
      out_.cam_from_world.clear();
      out_.points.clear();
      out_.log.push_back("pair " + a + ", " + b + ": " + std::to_string(n) + " points intersected (base too short)");
      return false;
    }
    out_.log.push_back("pair " + a + ", " + b + ": relative orientation on " + std::to_string(xa.size()) +
                       " common points, " + std::to_string(n) + " intersected");
    return true;
  }

  const BlockInput& in_;
  const BlockOptions& options_;
  BlockResult& out_;
  std::map<std::string, std::vector<Obs>> by_image_, by_point_;
  std::set<std::pair<std::string, std::string>> outlier_;  // (image, point)
  double gate_px_ = options_.max_error_px;  ///< intersection gate: max_error_px, or prior_max_error_px
  double gate_deg_ = options_.min_angle_deg;  ///< min_angle_deg, or prior_min_angle_deg
};

}  // namespace

bool BlockOptions::Check(std::string* error) const {
  if (!resection.Check(error)) return false;
  if (!(min_angle_deg > 0 && min_angle_deg < 90) || !(prior_min_angle_deg > 0 && prior_min_angle_deg < 90)) {
    *error = "min_angle_deg, prior_min_angle_deg: " + std::to_string(min_angle_deg) + ", " +
             std::to_string(prior_min_angle_deg) + ", expected (0, 90) degrees";
  } else if (!(max_error_px > 0) || !(relative_max_error_px > 0) || !(prior_max_error_px > 0)) {
    *error = "max_error_px, relative_max_error_px, prior_max_error_px: expected > 0 pixels";
  } else {
    return true;
  }
  return false;
}

BlockResult InitialiseBlock(const BlockInput& input, const BlockOptions& options) {
  BlockResult result;
  Block block(input, options, &result);
  if (!block.SeedFromPrior() && !block.SeedFromControl()) {
    result.failed_images.clear();
    result.points.clear();
    if (block.SeedFromPair()) {
      block.Grow();
      block.MoveOntoControl();
      block.ReportLeftovers();
      return result;
    }
    result.frame = "none";
  }
  block.Grow();
  block.ReportLeftovers();
  return result;
}

}  // namespace mmba::orientation
