// All PCL use of the cloud registration (kept to this one translation unit: PCL headers are
// heavy). PCL 1.13.

#include "registration/cloud/pcl_backend.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <pcl/console/print.h>
#include <pcl/features/3dsc.h>
#include <pcl/features/fpfh_omp.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/features/shot_omp.h>
#include <pcl/features/spin_image.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/keypoints/harris_3d.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "mmba/core/logging.h"

namespace mmba::registration::internal {

std::vector<size_t> StrideSample(size_t n, size_t max_count) {
  std::vector<size_t> out;
  const double step = n > max_count ? static_cast<double>(n) / max_count : 1.0;
  for (double x = 0; x < n && out.size() < max_count; x += step) {
    out.push_back(static_cast<size_t>(x));
  }
  return out;
}
namespace {

constexpr int kThreads = 2;

// `points` − `origin` as floats (origin: io::LocalOrigin of the cloud they belong to).
pcl::PointCloud<pcl::PointXYZ>::Ptr ToPcl(const std::vector<Eigen::Vector3d>& points,
                                          const Eigen::Vector3d& origin) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->resize(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    (*cloud)[i].getVector3fMap() = (points[i] - origin).cast<float>();
  }
  cloud->width = static_cast<uint32_t>(points.size());
  cloud->height = 1;
  cloud->is_dense = true;
  return cloud;
}

pcl::PointCloud<pcl::Normal>::Ptr ToPclNormals(const std::vector<Eigen::Vector3d>& normals) {
  pcl::PointCloud<pcl::Normal>::Ptr cloud(new pcl::PointCloud<pcl::Normal>);
  cloud->resize(normals.size());
  for (size_t i = 0; i < normals.size(); ++i) {
    (*cloud)[i].getNormalVector3fMap() = normals[i].cast<float>();
    (*cloud)[i].curvature = 0.0f;
  }
  cloud->width = static_cast<uint32_t>(normals.size());
  cloud->height = 1;
  return cloud;
}

// PCL prints its per-point complaints to stderr ("the local reference frame is not valid!
// Aborting description of point …": SHOT on a keypoint with too few neighbours); such a
// keypoint gets no descriptor and the matching skips it. Shown with --verbose only.
void QuietPcl() {
  pcl::console::setVerbosityLevel(spdlog::should_log(spdlog::level::debug)
                                      ? pcl::console::L_WARN
                                      : pcl::console::L_ALWAYS);
}

}  // namespace

// Exact nearest neighbours by brute force: ‖a − b‖² = ‖a‖² + ‖b‖² − 2 a·b over all rows
// (a few thousand descriptors: a matrix-vector product per query). FLANN's randomised
// kd-trees were approximate (256 checks) and their matches varied from run to run.
struct FeatureIndex::Impl {
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> data;
  Eigen::VectorXf squared_norms;
};

FeatureIndex::FeatureIndex(const std::vector<float>& data, int dim) : impl_(new Impl) {
  rows_ = dim > 0 ? data.size() / dim : 0;
  if (rows_ == 0) return;
  impl_->data = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic,
                                               Eigen::RowMajor>>(data.data(), rows_, dim);
  impl_->squared_norms = impl_->data.rowwise().squaredNorm();
}
FeatureIndex::~FeatureIndex() = default;

void FeatureIndex::KNearest(const float* query, int k, std::vector<int>* indices,
                            std::vector<float>* squared_distances) const {
  indices->assign(k, -1);
  squared_distances->assign(k, std::numeric_limits<float>::infinity());
  if (rows_ == 0 || k <= 0) return;
  const Eigen::Map<const Eigen::VectorXf> q(query, impl_->data.cols());
  const Eigen::VectorXf d = (impl_->squared_norms - 2.0f * (impl_->data * q)).array() +
                            q.squaredNorm();
  std::vector<int> order(rows_);
  std::iota(order.begin(), order.end(), 0);
  const size_t kk = std::min<size_t>(static_cast<size_t>(k), rows_);
  // Ties broken by index: the result does not depend on the sort's implementation.
  std::partial_sort(order.begin(), order.begin() + static_cast<long>(kk), order.end(),
                    [&d](int a, int b) { return d[a] < d[b] || (d[a] == d[b] && a < b); });
  for (size_t i = 0; i < kk; ++i) {
    (*indices)[i] = order[i];
    (*squared_distances)[i] = std::max(0.0f, d[order[i]]);
  }
}

// Normals by PCL's NormalEstimationOMP. (A nanoflann/OpenMP version with double sums was
// tried: 0.1 s less CPU on the Stanford pair, normals within 0.05° of PCL's, but those tiny
// differences flipped the cathedral multi_view_part -> plane_proxy cell from ok at 5 mm to a
// failed 0.47 m; the fragile cell is kept on the normals its figures were measured with.)
std::vector<Eigen::Vector3d> EstimateNormals(const std::vector<Eigen::Vector3d>& points,
                                             double radius, const Eigen::Vector3d& viewpoint,
                                             const std::vector<size_t>* only) {
  QuietPcl();
  const Eigen::Vector3d origin = io::LocalOrigin(points);
  auto cloud = ToPcl(points, origin);
  pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> estimation(kThreads);
  estimation.setInputCloud(cloud);
  if (only != nullptr) {
    auto indices = std::make_shared<pcl::Indices>(only->begin(), only->end());
    estimation.setIndices(indices);
  }
  estimation.setRadiusSearch(radius);
  const Eigen::Vector3f local_viewpoint = (viewpoint - origin).cast<float>();
  estimation.setViewPoint(local_viewpoint.x(), local_viewpoint.y(), local_viewpoint.z());
  pcl::PointCloud<pcl::Normal> normals;
  estimation.compute(normals);
  std::vector<Eigen::Vector3d> out(normals.size());
  for (size_t i = 0; i < out.size(); ++i) {
    out[i] = normals[i].getNormalVector3fMap().cast<double>();
  }
  return out;
}

void OrientTowardsNearest(const std::vector<Eigen::Vector3d>& points,
                          const std::vector<Eigen::Vector3d>& viewpoints,
                          std::vector<Eigen::Vector3d>* normals) {
  if (viewpoints.empty()) return;
  for (size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector3d& n = (*normals)[i];
    if (!n.allFinite()) continue;
    const Eigen::Vector3d* nearest = &viewpoints.front();
    for (const Eigen::Vector3d& v : viewpoints) {
      if ((v - points[i]).squaredNorm() < (*nearest - points[i]).squaredNorm()) nearest = &v;
    }
    if (n.dot(*nearest - points[i]) < 0.0) n = -n;
  }
}

std::vector<float> TomasiResponse(const std::vector<Eigen::Vector3d>& points,
                                  const std::vector<Eigen::Vector3d>& normals, double radius) {
  QuietPcl();
  auto cloud = ToPcl(points, io::LocalOrigin(points));
  auto pcl_normals = ToPclNormals(normals);
  pcl::HarrisKeypoint3D<pcl::PointXYZ, pcl::PointXYZI, pcl::Normal> harris(
      pcl::HarrisKeypoint3D<pcl::PointXYZ, pcl::PointXYZI, pcl::Normal>::TOMASI, radius);
  harris.setInputCloud(cloud);
  harris.setNormals(pcl_normals);
  harris.setNonMaxSupression(false);  // the grid selection is done by the caller
  harris.setRefine(false);
  harris.setNumberOfThreads(kThreads);
  pcl::PointCloud<pcl::PointXYZI> response;
  harris.compute(response);
  std::vector<float> out(points.size(), 0.0f);
  for (size_t i = 0; i < response.size() && i < out.size(); ++i) {
    out[i] = std::isfinite(response[i].intensity) ? response[i].intensity : 0.0f;
  }
  return out;
}

namespace {

template <typename Feature, typename Get>
void CopyDescriptors(const pcl::PointCloud<Feature>& features, int dim, Get get,
                     Descriptors* out) {
  out->dim = dim;
  out->data.assign(features.size() * dim, 0.0f);
  out->valid.assign(features.size(), true);
  for (size_t i = 0; i < features.size(); ++i) {
    const float* f = get(features[i]);
    bool finite = true, nonzero = false;
    for (int k = 0; k < dim; ++k) {
      if (!std::isfinite(f[k])) finite = false;
      if (f[k] != 0.0f) nonzero = true;
    }
    out->valid[i] = finite && nonzero;
    if (out->valid[i]) std::copy(f, f + dim, out->data.begin() + i * dim);
  }
}

// The PCL clouds of a descriptor computation, relative to one local origin (float
// precision): the surface, its normals and the keypoints.
struct PclDescriptorInput {
  pcl::PointCloud<pcl::PointXYZ>::Ptr surface;
  pcl::PointCloud<pcl::Normal>::Ptr surface_normals;
  pcl::PointCloud<pcl::PointXYZ>::Ptr keypoints;
};

PclDescriptorInput ToPclDescriptorInput(const std::vector<Eigen::Vector3d>& points,
                                        const std::vector<Eigen::Vector3d>& normals,
                                        const std::vector<int>& keypoints) {
  QuietPcl();
  const Eigen::Vector3d origin = io::LocalOrigin(points);
  std::vector<Eigen::Vector3d> kp_points;
  for (int i : keypoints) kp_points.push_back(points[i]);
  return {ToPcl(points, origin), ToPclNormals(normals), ToPcl(kp_points, origin)};
}

// Runs a PCL feature estimator at in.keypoints over in.surface (with its normals) within
// `radius`; other settings of `est` are made by the caller.
template <typename Signature, typename Estimator>
pcl::PointCloud<Signature> EstimateAtKeypoints(Estimator& est, const PclDescriptorInput& in,
                                               double radius) {
  est.setInputCloud(in.keypoints);
  est.setSearchSurface(in.surface);
  est.setInputNormals(in.surface_normals);
  est.setRadiusSearch(radius);
  pcl::PointCloud<Signature> f;
  est.compute(f);
  return f;
}

}  // namespace

Descriptors ComputeDescriptors(Descriptor descriptor, const std::vector<Eigen::Vector3d>& points,
                               const std::vector<Eigen::Vector3d>& normals,
                               const std::vector<int>& keypoints, double radius,
                               const Eigen::Vector3d* up) {
  const PclDescriptorInput in = ToPclDescriptorInput(points, normals, keypoints);
  Descriptors out;
  switch (descriptor) {
    case Descriptor::kFpfh:
      return ComputeFpfh(points, normals, keypoints, radius);
    case Descriptor::kShot: {
      pcl::SHOTEstimationOMP<pcl::PointXYZ, pcl::Normal, pcl::SHOT352> est(kThreads);
      const auto f = EstimateAtKeypoints<pcl::SHOT352>(est, in, radius);
      CopyDescriptors(f, 352, [](const pcl::SHOT352& s) { return s.descriptor; }, &out);
      break;
    }
    case Descriptor::kSpinImage: {
      // 8 bins a side, support angle cosine 0.5, >= 16 neighbours (Kim & Hilton Sec. 3.2).
      // PCL 1.13 indexes the input normals with the neighbours' surface indices, so the
      // input is the whole surface and the keypoints are given as indices.
      // PCL throws for a keypoint with fewer than 16 neighbours within the radius: those are
      // left out (invalid) instead.
      constexpr int kMinNeighbours = 16;
      pcl::KdTreeFLANN<pcl::PointXYZ> tree;
      tree.setInputCloud(in.surface);
      std::vector<int> kept;  // positions in `keypoints`
      pcl::Indices nn;
      std::vector<float> nn_sq;
      for (size_t i = 0; i < keypoints.size(); ++i) {
        if (tree.radiusSearch((*in.surface)[keypoints[i]], radius, nn, nn_sq) >= kMinNeighbours) {
          kept.push_back(static_cast<int>(i));
        }
      }
      out.dim = 153;
      out.data.assign(keypoints.size() * 153, 0.0f);
      out.valid.assign(keypoints.size(), false);
      if (kept.empty()) break;
      auto indices = pcl::IndicesPtr(new pcl::Indices());
      for (int i : kept) indices->push_back(keypoints[i]);
      pcl::SpinImageEstimation<pcl::PointXYZ, pcl::Normal, pcl::Histogram<153>> est(
          8, 0.5, kMinNeighbours);
      est.setInputCloud(in.surface);
      est.setIndices(indices);
      est.setInputNormals(in.surface_normals);
      if (up != nullptr) {
        pcl::Normal axis;
        axis.getNormalVector3fMap() = up->cast<float>();
        est.setRotationAxis(axis);
      }
      est.setRadiusSearch(radius);
      pcl::PointCloud<pcl::Histogram<153>> f;
      est.compute(f);
      Descriptors computed;
      CopyDescriptors(f, 153, [](const pcl::Histogram<153>& s) { return s.histogram; }, &computed);
      for (size_t k = 0; k < kept.size() && k < computed.valid.size(); ++k) {
        out.valid[kept[k]] = computed.valid[k];
        std::copy(computed.data.begin() + k * 153, computed.data.begin() + (k + 1) * 153,
                  out.data.begin() + kept[k] * 153);
      }
      break;
    }
    case Descriptor::kShapeContext: {
      // 12 azimuth × 11 elevation × 15 log-radial bins (PCL defaults = Frome et al.).
      pcl::ShapeContext3DEstimation<pcl::PointXYZ, pcl::Normal, pcl::ShapeContext1980> est;
      est.setMinimalRadius(radius / 10.0);
      est.setPointDensityRadius(radius / 5.0);
      const auto f = EstimateAtKeypoints<pcl::ShapeContext1980>(est, in, radius);
      CopyDescriptors(f, 1980, [](const pcl::ShapeContext1980& s) { return s.descriptor; },
                      &out);
      break;
    }
    case Descriptor::kAuto:
      break;
  }
  return out;
}

Descriptors ComputeFpfhPcl(const std::vector<Eigen::Vector3d>& points,
                           const std::vector<Eigen::Vector3d>& normals,
                           const std::vector<int>& keypoints, double radius) {
  const PclDescriptorInput in = ToPclDescriptorInput(points, normals, keypoints);
  pcl::FPFHEstimationOMP<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33> est(kThreads);
  const auto f = EstimateAtKeypoints<pcl::FPFHSignature33>(est, in, radius);
  Descriptors out;
  CopyDescriptors(f, 33, [](const pcl::FPFHSignature33& s) { return s.histogram; }, &out);
  return out;
}

}  // namespace mmba::registration::internal
