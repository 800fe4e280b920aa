#include "mmba/registration/mi/mi_registration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

#include <glog/logging.h>

#include "mmba/core/logging.h"
#include "mmba/core/parallel_for.h"
#include "mmba/core/progress.h"
#include "registration/mi/evaluator_cull.h"
#include "registration/mi/mi_internal.h"
#include "registration/mi/pinhole_block.h"

namespace mmba::registration::mi {

using internal::kDegToRad;
using internal::ThreadBuffer;
using internal::CoreFreeForSplit;
using internal::kMinPointsToSplit;
using internal::ParallelFor;
using internal::PixelDifference;
using internal::Median;
using internal::RenderOrder;
using internal::PinholeCull;
using internal::CullPinholeBlocks;

namespace {

// Which candidates of `all` (all points, or `candidates`' indices into them) project into
// some view of `views` at `start`, each view expanded by what the rotation bound can move a
// pixel plus a margin for the translation bound. Returns the kept point indices in order.
std::vector<size_t> CullToViews(const std::vector<View>& views, const LidarPoints& all,
                                const std::vector<uint32_t>* candidates, const Rigid3d& start,
                                const RegistrationOptions& options) {
  const double rot_margin = std::tan(options.bound_rotation_deg * kDegToRad);
  const size_t tested = candidates != nullptr ? candidates->size() : all.size();
  std::vector<char> keep(tested, 0);
  // Candidates [begin, end) against every view (keep[k]: candidate k is kept).
  auto cull = [&](size_t begin, size_t end) {
    for (const View& view : views) {
      const auto [rotation, translation] = MakeTransform(view, start);
      const double focal = view.camera.MeanFocalLength();
      const bool spherical = view.camera.IsSpherical();
      const double max_range = options.render.max_range_m + options.bound_translation_m;
      const double near_range = 2.0 * options.bound_translation_m + options.render.min_range_m;
      if (view.camera.model_id == sensors::CameraModelId::kPinhole) {
        const PinholeCull test{rotation, translation, view.camera, focal, rot_margin,
                               options.bound_translation_m, max_range, near_range};
        CullPinholeBlocks(test, all, candidates, begin, end, keep.data());
        continue;
      }
      for (size_t k = begin; k < end; ++k) {
        if (keep[k]) continue;
        const size_t i = candidates != nullptr ? (*candidates)[k] : k;
        const Eigen::Vector3f p = rotation * all.points_in_lidar[i] + translation;
        const double range = p.norm();
        if (range > max_range) continue;
        if (spherical || range < near_range) {
          keep[k] = 1;
          continue;
        }
        if (p.z() <= 0.f) continue;
        const std::optional<Eigen::Vector2d> xy = view.camera.ImgFromCam(p.cast<double>());
        if (!xy) continue;
        const double margin = focal * (rot_margin + options.bound_translation_m / range) + 8.0;
        if ((*xy)[0] >= -margin && (*xy)[1] >= -margin &&
            (*xy)[0] <= view.camera.width + margin && (*xy)[1] <= view.camera.height + margin) {
          keep[k] = 1;
        }
      }
    }
  };
  // Two threads over the two halves of the points (each point's test is independent).
  if (options.threads >= 2 && CoreFreeForSplit() && tested >= 2 * kMinPointsToSplit) {
    OnThreads(2, [&](int t, int) { t == 0 ? cull(0, tested / 2) : cull(tested / 2, tested); });
  } else {
    cull(0, tested);
  }
  // The kept indices in order, without a branch per point (each written, then counted
  // when kept; one slot more for the last write).
  const size_t kept_count = tested - std::count(keep.begin(), keep.end(), 0);
  std::vector<size_t> kept(kept_count + 1);
  for (size_t k = 0, j = 0; k < tested; ++k) {
    kept[j] = candidates != nullptr ? (*candidates)[k] : k;
    j += keep[k] != 0;
  }
  kept.resize(kept_count);
  return kept;
}

// The points of one pyramid level: an even subsample of `kept` (coarser levels keep more
// points per, larger, pixel: a dense coarse image keeps the basin of convergence wide;
// measured: 0.75 at every level lost a 0.3 m / 2° start), in render order.
LidarPoints LevelSubset(const std::vector<size_t>& kept, const LidarPoints& all, const std::vector<View>& views,
                        int level, const Rigid3d& start, const RegistrationOptions& options) {
  double pixels = 0;
  for (const View& view : views) pixels += static_cast<double>(view.camera.width) * view.camera.height;
  const double cap = options.max_points_per_pixel * std::pow(2.0, level) * pixels;
  const double stride = std::max(1.0, kept.size() / cap);
  std::vector<size_t> chosen;
  for (double k = 0; k < kept.size(); k += stride) chosen.push_back(kept[static_cast<size_t>(k)]);
  // Their points and intensities in the subsample's order (read through the cloud once).
  std::vector<Eigen::Vector3f> chosen_points(chosen.size());
  std::vector<float> chosen_intensity(all.has_intensity() ? chosen.size() : 0);
  for (size_t k = 0; k < chosen.size(); ++k) chosen_points[k] = all.points_in_lidar[chosen[k]];
  for (size_t k = 0; k < chosen_intensity.size(); ++k) chosen_intensity[k] = all.intensity01[chosen[k]];
  // Render order: the points sorted by the pixel they fall on at the start pose (view, row,
  // column), so that a render writes the z-buffer almost sequentially instead of scattering
  // over the whole image in the cloud's order (measured: the z-buffer's cache misses were the
  // largest single cost of an evaluation). Each point keeps its position in the even
  // subsample as its rank (LidarPoints::tie_rank): equally near points compete in that
  // order, and what depends on a point order (SampleVisiblePoints) is the same as unsorted —
  // the same images and results, bit for bit.
  const std::vector<uint32_t> order = RenderOrder(chosen_points, views, start, options.render);
  LidarPoints subset;
  subset.points_in_lidar.resize(chosen.size());
  subset.intensity01.resize(chosen_intensity.size());
  subset.tie_rank = order;
  subset.index_of_rank.resize(order.size());
  for (size_t j = 0; j < order.size(); ++j) {
    const uint32_t k = order[j];
    subset.points_in_lidar[j] = chosen_points[k];
    if (!chosen_intensity.empty()) subset.intensity01[j] = chosen_intensity[k];
    subset.index_of_rank[k] = static_cast<uint32_t>(j);
  }
  return subset;
}

}  // namespace

FrameSetEvaluator::FrameSetEvaluator(const std::vector<Frame>& frames,
                                     const Rigid3d& cam_from_lidar_start,
                                     const RegistrationOptions& options,
                                     const FrameSetEvaluator* parent)
    : frames_(frames), options_(options), start_(cam_from_lidar_start) {
  for (const Frame& frame : frames_) {
    CHECK(frame.points == nullptr || frame.points->classes <= options.metric.lidar_classes)
        << frame.name << ": points carry " << frame.points->classes
        << " surface classes but the metric is conditioned on " << options.metric.lidar_classes;
  }
  const int levels = options.pyramid_levels;
  pyramid_.resize(levels);
  points_.resize(levels);
  kept_.resize(frames_.size());
  for (const Frame& frame : frames_) pyramid_[0].push_back(frame.views);
  for (int level = 1; level < levels; ++level) {
    for (const std::vector<View>& views : pyramid_[level - 1]) {
      std::vector<View> half;
      for (const View& view : views) half.push_back(DownsampleView(view));
      pyramid_[level].push_back(std::move(half));
    }
  }
  if (parent != nullptr) {
    CHECK(parent->start_.rotation.coeffs() == start_.rotation.coeffs() &&
          parent->start_.translation == start_.translation &&
          parent->options_.bound_translation_m == options.bound_translation_m &&
          parent->options_.bound_rotation_deg == options.bound_rotation_deg &&
          parent->options_.render.max_range_m == options.render.max_range_m &&
          parent->options_.render.min_range_m == options.render.min_range_m)
        << "a part's evaluator needs its parent's start pose, bounds and ranges";
  }
  for (size_t f = 0; f < frames_.size(); ++f) {
    const LidarPoints& all = *frames_[f].points;
    // The points to test: all, or those the parent kept for the frame these views were
    // taken from (its views contain these: what one of them keeps, the parent kept).
    const std::vector<uint32_t>* candidates = nullptr;
    if (parent != nullptr) {
      int match = -1, matches = 0;
      for (size_t g = 0; g < parent->frames_.size(); ++g) {
        if (parent->frames_[g].points == frames_[f].points && parent->frames_[g].name == frames_[f].name) {
          match = static_cast<int>(g);
          ++matches;
        }
      }
      if (matches == 1 && !parent->kept_[match].empty()) candidates = &parent->kept_[match];
    }
    const std::vector<size_t> kept = CullToViews(frames_[f].views, all, candidates, cam_from_lidar_start, options);
    // What the parts' evaluators (the halves) test instead of the whole cloud.
    if (parent == nullptr && all.size() < (size_t{1} << 32)) kept_[f].assign(kept.begin(), kept.end());
    // The levels' subsets on the threads (each independent of the others).
    std::vector<LidarPoints> subsets(levels);
    ParallelFor(levels, CoreFreeForSplit() ? options.threads : 1, [&](int level) {
      subsets[level] = LevelSubset(kept, all, pyramid_[level][f], level, cam_from_lidar_start, options);
    });
    for (int level = 0; level < levels; ++level) points_[level].push_back(std::move(subsets[level]));
  }
}

MetricValue FrameSetEvaluator::Evaluate(const Rigid3d& cam_from_lidar, int level,
                                        const MetricOptions& metric) const {
  LidarImage& buffer = ThreadBuffer();
  // Each pyramid level has a quarter of the samples; halving the bins keeps the plug-in
  // estimator's bias, ≈ (bins_x − 1)(bins_y − 1) / (2N) (Miller 1955), the same at every level.
  MetricOptions level_metric = metric;
  level_metric.bins = std::max(8, metric.bins >> level);
  JointHistogram histogram(level_metric);
  for (size_t f = 0; f < frames_.size(); ++f) {
    // The footprints drawn by two threads when a core is free (the same image).
    const bool two_threads = options_.threads >= 2 && CoreFreeForSplit() &&
                             points_[level][f].size() >= kMinPointsToSplit;
    for (const View& view : pyramid_[level][f]) {
      // The B-spline histogram (the default) reads each pixel's winner from the z-buffer:
      // the same sums as rendering the full image first, without its per-pixel arrays.
      const bool zbuffer_only = level_metric.smoothing == Smoothing::kBSpline;
      Timer render;
      if (zbuffer_only) {
        RenderLidarZBuffer(points_[level][f], view, cam_from_lidar, options_.render, &buffer,
                           two_threads);
      } else {
        RenderLidarImage(points_[level][f], view, cam_from_lidar, options_.render, &buffer,
                         two_threads);
      }
      render_ns_ += static_cast<int64_t>(1e9 * render.ElapsedSeconds());
      Timer fill;
      if (zbuffer_only) {
        histogram.AddZBuffer(buffer, points_[level][f], options_.render, view.image);
      } else {
        histogram.Add(buffer, view.image);
      }
      histogram_ns_ += static_cast<int64_t>(1e9 * fill.ElapsedSeconds());
    }
  }
  Timer fill;
  const MetricValue value = histogram.Evaluate();
  histogram_ns_ += static_cast<int64_t>(1e9 * fill.ElapsedSeconds());
  return value;
}

bool FrameSetEvaluator::SplitRender(const LidarPoints& points) const {
  return options_.threads >= 2 && CoreFreeForSplit() && points.size() >= kMinPointsToSplit;
}

bool FrameSetEvaluator::UsesSamples(const MetricOptions& metric) const {
  if (!options_.point_samples || metric.smoothing != Smoothing::kBSpline) return false;
  if (metric.region == Region::kOverlap) return true;
  // Whole image: the sample sets carry the background of the options' metric only.
  return options_.metric.region == Region::kWholeImage && metric.bins == options_.metric.bins;
}

FrameSetEvaluator::SampleSet FrameSetEvaluator::MakeSampleSet(const Rigid3d& cam_from_lidar,
                                                              int level, bool per_point) const {
  Timer timer;
  LidarImage& buffer = ThreadBuffer();
  SampleSet set;
  set.level = level;
  set.reference = cam_from_lidar;
  PerPointPlacement placement;
  placement.block_px = options_.sample_block_px;
  for (size_t f = 0; f < frames_.size(); ++f) {
    const bool two_threads = options_.threads >= 2 && CoreFreeForSplit() &&
                             points_[level][f].size() >= kMinPointsToSplit;
    for (const View& view : pyramid_[level][f]) {
      RenderLidarImage(points_[level][f], view, cam_from_lidar, options_.render, &buffer,
                       two_threads);
      set.views.push_back(
          MakeViewSamples(points_[level][f], buffer, options_.render, per_point, placement));
      set.samples += set.views.back().samples();
      if (options_.metric.region == Region::kWholeImage) {
        // The reference's background pixels and its samples' photo values, one histogram:
        // what the background is at any pose once the samples' values are taken out of it.
        MetricOptions level_metric = options_.metric;
        level_metric.bins = std::max(8, options_.metric.bins >> level);
        level_metric.smoothing = Smoothing::kBSpline;
        JointHistogram rendered(level_metric), sampled(level_metric);
        rendered.Add(buffer, view.image);
        AccumulateViewSamples(set.views.back(), view, cam_from_lidar, options_.render, 0,
                              set.views.back().points(), &sampled);
        std::vector<double> background = rendered.PaddedEmptyPhoto();
        const std::vector<double> covered = sampled.PaddedCoveredPhoto();
        for (size_t q = 0; q < background.size(); ++q) background[q] += covered[q];
        set.background.push_back(std::move(background));
        set.view_pixels.push_back(static_cast<double>(view.camera.width) * view.camera.height);
      }
    }
  }
  ++sample_sets_;
  render_ns_ += static_cast<int64_t>(1e9 * timer.ElapsedSeconds());
  return set;
}

double FrameSetEvaluator::SampleSetDisplacementPx(const SampleSet& set,
                                                  const Rigid3d& cam_from_lidar) const {
  double largest = 0;
  size_t v = 0;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (const View& view : pyramid_[set.level][f]) {
      largest = std::max(largest, ProbeDisplacementPx(set.views[v++], view, cam_from_lidar));
    }
  }
  return largest;
}

MetricValue FrameSetEvaluator::Evaluate(const Rigid3d& cam_from_lidar, int level,
                                        const MetricOptions& metric, const SampleSet* set) const {
  if (set == nullptr || set->level != level || !UsesSamples(metric)) {
    return Evaluate(cam_from_lidar, level, metric);
  }
  Timer timer;
  MetricOptions level_metric = metric;
  level_metric.bins = std::max(8, metric.bins >> level);
  // Two partial histograms over the two halves of each view's points, merged: the same sums
  // whether they were filled on one thread or two.
  std::array<JointHistogram, 2> parts = {JointHistogram(level_metric),
                                         JointHistogram(level_metric)};
  auto fill = [&](int h) {
    size_t v = 0;
    for (size_t f = 0; f < frames_.size(); ++f) {
      for (const View& view : pyramid_[level][f]) {
        const ViewSamples& samples = set->views[v++];
        const size_t half = samples.points() / 2;
        AccumulateViewSamples(samples, view, cam_from_lidar, options_.render,
                              h == 0 ? 0 : half, h == 0 ? half : samples.points(), &parts[h]);
      }
    }
  };
  // Splitting pays above several thousand samples (a thread costs ~20 µs here, an
  // evaluation of 15 000 samples ~0.4 ms: the coarsest level of a 940×452 view).
  if (options_.threads >= 2 && CoreFreeForSplit() && set->samples >= 8000) {
    OnThreads(2, [&](int t, int) { fill(t); });
  } else {
    fill(0);
    fill(1);
  }
  parts[0].Merge(parts[1]);
  if (level_metric.region == Region::kWholeImage) {
    CHECK_EQ(set->background.size(), set->views.size()) << "a sample set without background";
    for (size_t v = 0; v < set->background.size(); ++v) {
      parts[0].AddBackgroundComplement(set->background[v].data(), set->view_pixels[v]);
    }
  }
  const MetricValue value = parts[0].Evaluate();
  ++sample_evaluations_;
  sample_ns_ += static_cast<int64_t>(1e9 * timer.ElapsedSeconds());
  return value;
}

double FrameSetEvaluator::CoveredFraction(const Rigid3d& cam_from_lidar) const {
  LidarImage& buffer = ThreadBuffer();
  double covered = 0, pixels = 0;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (const View& view : pyramid_[0][f]) {
      RenderLidarImage(points_[0][f], view, cam_from_lidar, options_.render, &buffer,
                       SplitRender(points_[0][f]));
      covered += buffer.covered_pixels;
      pixels += static_cast<double>(buffer.width) * buffer.height;
    }
  }
  return pixels > 0 ? covered / pixels : 0.0;
}

double FrameSetEvaluator::EffectiveSamples(const Rigid3d& cam_from_lidar, int level,
                                           int max_lag, double* inflation) const {
  LidarImage& buffer = ThreadBuffer();
  double covered_pixels = 0, weighted = 0;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (const View& view : pyramid_[level][f]) {
      RenderLidarImage(points_[level][f], view, cam_from_lidar, options_.render, &buffer,
                       SplitRender(points_[level][f]));
      const int w = buffer.width, h = buffer.height;
      const size_t pixels = buffer.value.size();
      auto covered = [&](size_t k) { return buffer.point_index[k] >= 0; };
      // The intensity without its surface class (class + fraction with several classes).
      const bool classed = options_.metric.lidar_classes > 1;
      auto value = [&](size_t k) {
        const float v = buffer.value[k];
        return classed ? v - std::floor(v) : v;
      };
      // The pose is found from where the two images change: the score of a registration is a
      // sum of gradient-weighted terms, so the correlation that matters is that of the
      // gradient fields (central differences where both neighbours are covered).
      std::vector<float> lx(pixels, 0.f), ly(pixels, 0.f), px(pixels, 0.f), py(pixels, 0.f);
      std::vector<char> on(pixels, 0);
      double n = 0, ll = 0, pp = 0;
      for (int y = 1; y + 1 < h; ++y) {
        for (int x = 1; x + 1 < w; ++x) {
          const size_t k = static_cast<size_t>(y) * w + x;
          if (!covered(k) || !covered(k - 1) || !covered(k + 1) || !covered(k - w) ||
              !covered(k + w)) {
            continue;
          }
          on[k] = 1;
          lx[k] = value(k + 1) - value(k - 1);
          ly[k] = value(k + w) - value(k - w);
          px[k] = view.image.pixels[k + 1] - view.image.pixels[k - 1];
          py[k] = view.image.pixels[k + w] - view.image.pixels[k - w];
          n += 1;
          ll += lx[k] * lx[k] + ly[k] * ly[k];
          pp += px[k] * px[k] + py[k] * py[k];
        }
      }
      if (n < 16 || !(ll > 0) || !(pp > 0)) continue;
      // Σ over lags of ρ_L·ρ_P (Bartlett); ρ(−lag) = ρ(lag), so the half plane dy > 0 or
      // (dy = 0, dx > 0) counts twice and lag 0 (ρ = 1) once.
      // Each lag's term on its own (the lags shared out over the threads), then summed in
      // lag order: the same sum on any number of threads.
      std::vector<std::pair<int, int>> lags;
      for (int dy = 0; dy <= max_lag; ++dy) {
        for (int dx = -max_lag; dx <= max_lag; ++dx) {
          if (dy == 0 && dx <= 0) continue;
          lags.emplace_back(dy, dx);
        }
      }
      // The columns of each row's pixels that are on, in order: a lag visits only those
      // (the same pairs, added in the same order, as a scan of every pixel).
      std::vector<int> on_columns;
      std::vector<size_t> row_begin(h + 1, 0);
      for (int y = 0; y < h; ++y) {
        row_begin[y] = on_columns.size();
        for (int x = 0; x < w; ++x) {
          if (on[static_cast<size_t>(y) * w + x]) on_columns.push_back(x);
        }
      }
      row_begin[h] = on_columns.size();
      std::vector<double> terms(lags.size(), 0.0);
      ParallelFor(static_cast<int>(lags.size()), CoreFreeForSplit() ? options_.threads : 1,
                  [&](int l) {
        const auto [dy, dx] = lags[l];
        // Without a branch per pixel: a partner that is not on has zero gradients, so its
        // term is ±0 and leaves the sums as they are (they start at +0 and never become −0),
        // and it counts 0 pairs; the columns whose partner is outside the row are cut off by
        // a search in the row's sorted on-columns. The same sums as adding the on pairs only.
        double pairs = 0, cl = 0, cp = 0;
        const int x0 = std::max(0, -dx), x1 = std::min(w, w - dx);
        for (int y = 0; y + dy < h; ++y) {
          const size_t row = static_cast<size_t>(y) * w, row2 = static_cast<size_t>(y + dy) * w;
          const int* first = on_columns.data() + row_begin[y];
          const int* last = on_columns.data() + row_begin[y + 1];
          const int* begin = std::lower_bound(first, last, x0);
          const int* end = std::lower_bound(begin, last, x1);
          for (const int* column = begin; column < end; ++column) {
            const int x = *column;
            const size_t a = row + x, b = row2 + x + dx;
            pairs += static_cast<double>(on[b]);
            cl += lx[a] * lx[b] + ly[a] * ly[b];
            cp += px[a] * px[b] + py[a] * py[b];
          }
        }
        if (pairs < 16) return;
        terms[l] = 2.0 * (cl / pairs) / (ll / n) * (cp / pairs) / (pp / n);
      });
      double factor = 1.0;
      for (double term : terms) factor += term;  // + 0 for a lag with too few pairs
      factor = std::max(1.0, factor);
      covered_pixels += static_cast<double>(buffer.covered_pixels);
      weighted += static_cast<double>(buffer.covered_pixels) / factor;
    }
  }
  if (inflation != nullptr) *inflation = weighted > 0 ? covered_pixels / weighted : 1.0;
  return weighted;
}

size_t FrameSetEvaluator::VisiblePoints(const Rigid3d& cam_from_lidar, int level) const {
  LidarImage& buffer = ThreadBuffer();
  size_t visible = 0;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (const View& view : pyramid_[level][f]) {
      RenderLidarImage(points_[level][f], view, cam_from_lidar, options_.render, &buffer,
                       SplitRender(points_[level][f]));
      visible += CountVisiblePoints(buffer);
    }
  }
  return visible;
}

void FrameSetEvaluator::EvaluateShuffled(const Rigid3d& cam_from_lidar, int level, int shuffles,
                                         double* mi_bits,
                                         std::vector<double>* shuffled_mi_bits) const {
  LidarImage& buffer = ThreadBuffer();
  MetricOptions metric = options_.metric;
  metric.kind = MetricKind::kMi;
  metric.bins = std::max(8, metric.bins >> level);
  const bool whole = metric.region == Region::kWholeImage;
  std::vector<float> lidar, photo;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (const View& view : pyramid_[level][f]) {
      RenderLidarImage(points_[level][f], view, cam_from_lidar, options_.render, &buffer,
                       SplitRender(points_[level][f]));
      for (size_t k = 0; k < buffer.value.size(); ++k) {
        const bool covered = buffer.point_index[k] >= 0;
        if (!covered && !whole) continue;
        lidar.push_back(covered ? buffer.value[k] : -1.f);
        photo.push_back(view.image.pixels[k]);
      }
    }
  }
  // The permutations one after the other (each shuffles the previous one), then the
  // histograms of the pairing and of each permutation on the threads: the same values.
  std::vector<std::vector<float>> photos(shuffles + 1);
  photos[0] = std::move(photo);
  std::mt19937 rng(20120616);
  for (int s = 1; s <= shuffles; ++s) {
    photos[s] = photos[s - 1];
    std::shuffle(photos[s].begin(), photos[s].end(), rng);
  }
  std::vector<double> mi(shuffles + 1);
  ParallelFor(shuffles + 1, CoreFreeForSplit() ? options_.threads : 1, [&](int s) {
    JointHistogram histogram(metric);
    histogram.AddPairs(lidar, photos[s]);
    mi[s] = histogram.Evaluate().mi;
  });
  *mi_bits = mi[0];
  shuffled_mi_bits->assign(mi.begin() + 1, mi.end());
}

std::vector<FrameSetEvaluator::VisiblePoint> FrameSetEvaluator::SampleVisiblePoints(
    const Rigid3d& cam_from_lidar, size_t max_points) const {
  LidarImage& buffer = ThreadBuffer();
  std::vector<VisiblePoint> all;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (size_t v = 0; v < pyramid_[0][f].size(); ++v) {
      RenderLidarImage(points_[0][f], pyramid_[0][f][v], cam_from_lidar, options_.render,
                       &buffer, SplitRender(points_[0][f]));
      // The winners in the order of the even subsample (not the render order), as the
      // points were before they were sorted for rendering.
      const std::vector<uint32_t>& order = points_[0][f].tie_rank;
      std::vector<std::pair<uint32_t, int>> winners;  // (position in the subsample, index)
      for (int index : buffer.point_index) {
        if (index >= 0) winners.emplace_back(order[index], index);
      }
      std::sort(winners.begin(), winners.end());
      winners.erase(std::unique(winners.begin(), winners.end()), winners.end());
      for (const auto& [position, index] : winners) {
        all.push_back({static_cast<int>(f), static_cast<int>(v),
                       points_[0][f].points_in_lidar[index].cast<double>()});
      }
    }
  }
  if (all.size() <= max_points) return all;
  std::vector<VisiblePoint> sample;
  const double stride = static_cast<double>(all.size()) / max_points;
  for (double k = 0; k < all.size() && sample.size() < max_points; k += stride) {
    sample.push_back(all[static_cast<size_t>(k)]);
  }
  return sample;
}

bool FrameSetEvaluator::Project(const VisiblePoint& point, const Rigid3d& cam_from_lidar,
                                Eigen::Vector2d* pixel) const {
  const View& view = pyramid_[0][point.frame][point.view];
  const Eigen::Vector3d p =
      view.view_from_cam * (cam_from_lidar * point.point_in_lidar) + view.view_from_cam_t;
  if (!view.camera.IsSpherical() && p.z() <= 0) return false;
  const std::optional<Eigen::Vector2d> xy = view.camera.ImgFromCam(p);
  if (!xy) return false;
  *pixel = *xy;
  return true;
}

double FrameSetEvaluator::MedianPixelDistance(const std::vector<VisiblePoint>& sample,
                                              const Rigid3d& a, const Rigid3d& b) const {
  std::vector<double> distances;
  for (const VisiblePoint& point : sample) {
    Eigen::Vector2d pa, pb;
    if (!Project(point, a, &pa) || !Project(point, b, &pb)) continue;
    const View& view = pyramid_[0][point.frame][point.view];
    distances.push_back(view.image_pixels_per_pixel * PixelDifference(view, pa, pb).norm());
  }
  return Median(distances);
}

}  // namespace mmba::registration::mi
