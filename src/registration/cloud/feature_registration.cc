// Feature-based registration pipeline (Kim & Hilton 3DV 2013, Sec. 3) and its robust
// extensions; see include/mmba/registration/cloud/feature_registration.h.

#include "mmba/registration/cloud/feature_registration.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/core/error.h"
#include "mmba/core/logging.h"
#include "registration/cloud/cloud_levels.h"
#include "registration/cloud/pcl_backend.h"
#include "registration/cloud/registration_stages.h"

namespace mmba::registration {

using internal::Pick;
using internal::StrideSample;

namespace {

// Below this many points in a cloud, a failure's reason says the cloud has too few points
// (PCL's bunny thinned to 10-20 points fails, to 30 registers: (bench/RESULTS.md "The verification's thresholds")).
constexpr size_t kFewPointsForDescriptors = 30;

// RegisterClouds on clouds whose coordinates are small (see RegisterClouds below):
// `source_viewpoint` / `target_viewpoint` = each cloud's own origin in these coordinates,
// towards which its normals are oriented (the scanner of a scan in its own frame).
// `past_normals` (optional): set when the normals were estimated (the input passed its checks).
CloudRegistrationResult RegisterCloudsNearOrigin(const io::PointCloud& source_in,
                                                 const io::PointCloud& target_in,
                                                 const CloudRegistrationOptions& options,
                                                 const Eigen::Vector3d& source_viewpoint,
                                                 const Eigen::Vector3d& target_viewpoint,
                                                 bool* past_normals = nullptr) {
  std::string option_error;
  if (!options.Check(&option_error)) throw InputError::Message("registration options", option_error);
  internal::RegistrationContext ctx(source_in, target_in, options, source_viewpoint,
                                    target_viewpoint);
  // Long work shows progress: once a registration has run 10 s (large clouds), each stage
  // is logged as it ends (RegistrationContext::EndStage); a quick one stays silent.
  if (source_in.size() + target_in.size() > 4000000) {
    spdlog::info("registration: {} source and {} target points; thinning them to the coarse "
                 "and fine levels first", source_in.size(), target_in.size());
  }
  if (!internal::PrepareClouds(ctx) || !internal::BuildLevels(ctx) ||
      !internal::EstimateLevelNormals(ctx)) {
    return ctx.result;
  }
  if (past_normals != nullptr) *past_normals = true;
  if (!internal::DetectKeypoints(ctx) || !internal::DescribeAndMatch(ctx) ||
      !internal::GenerateHypotheses(ctx) || !internal::RefineCoarseHypotheses(ctx) ||
      !internal::PrepareFineLevel(ctx) || !internal::SelectFinalists(ctx)) {
    return ctx.result;
  }
  internal::SearchAlternatives(ctx);
  internal::TestAmbiguity(ctx);
  internal::EstimateUncertainty(ctx);
  internal::ReportFinalists(ctx);
  internal::Verdict(ctx);
  return ctx.result;
}

io::PointCloud Shifted(const io::PointCloud& cloud, const Eigen::Vector3d& offset) {
  io::PointCloud out = cloud;
  for (Eigen::Vector3d& p : out.points) p += offset;
  return out;
}

}  // namespace

// Each cloud is registered about its own centre c (io::MedianCentre: a blunder far away does
// not move it), and the result is mapped back: T = [I | c_t] · T_local · [I | −c_s]. The
// floats of the kd-trees and PCL then resolve a cloud at its own size (map-grid coordinates,
// 10^5–10^7 m, left them 0.01–0.5 m), and no step but the normals' orientation (below)
// depends on where the frame's origin lies.
// An ICP turning the source about a far origin moves it at each step by the turn's
// second-order term at that distance (10° at 30 m: 0.46 m), so the ICP turns the source about
// its own centroid.
// With a search window both clouds share the target's c, so that the given (identity) pose
// stays the identity.
// The normals of a cloud within 500 m of its origin (io::LocalOrigin is zero) are oriented
// towards that origin, its scanner when it is a scan in its own frame. Those of a cloud in a
// grid cannot be (its origin is thousands of km away, nearly level: ground normals would flip
// at random); they are oriented towards a point high above its centroid along `up` instead —
// ground up, walls towards the middle of the cloud, as a levelled scanner standing inside it
// sees them.
namespace {
// A levelled pair whose registered pose tilts the source by more than this gets a note.
constexpr double kLevelledTiltNote = 2.0 * M_PI / 180.0;

// In the cloud's coordinates about its centre (io::MedianCentre): high above it, ten times the
// cloud's robust extent (a blunder far away does not send the viewpoint there), measured on
// at most 100,000 evenly strided points (it runs once per cloud and per trial scale).
Eigen::Vector3d GridViewpoint(const io::PointCloud& cloud, const Eigen::Vector3d& up) {
  const double extent = RobustExtent(Pick(cloud.points, StrideSample(cloud.size(), 100000)));
  return std::max(100.0, 10.0 * extent) * up.normalized();
}

// NormalOrientation::kAuto: RegisterCloudsNearOrigin with the normals towards each cloud's
// origin (or sensors). When that fails after the normals stage with no pose that fits, and
// the two clouds do not both have sensor positions, it is tried again with kConsistentTurned
// (a scan moved into another frame, its origin behind its surfaces: bench/RESULTS.md,
// "Normals retried") and, when a cloud's normals are estimated without sensors, with
// kConsistent (part of a cloud turned against the rest). A retry's result is taken only when
// it is "ok"; the runtime counts every try.
CloudRegistrationResult RegisterCloudsNearOriginRetrying(const io::PointCloud& source,
                                                         const io::PointCloud& target,
                                                         const CloudRegistrationOptions& options,
                                                         const Eigen::Vector3d& source_viewpoint,
                                                         const Eigen::Vector3d& target_viewpoint) {
  if (options.normal_orientation != NormalOrientation::kAuto) {
    return RegisterCloudsNearOrigin(source, target, options, source_viewpoint, target_viewpoint);
  }
  CloudRegistrationOptions first_options = options;
  first_options.normal_orientation = NormalOrientation::kViewpoint;
  bool past_normals = false;
  CloudRegistrationResult first = RegisterCloudsNearOrigin(
      source, target, first_options, source_viewpoint, target_viewpoint, &past_normals);
  // A first try whose best pose fits (overlap, normals, visibility) and was refused as
  // ambiguous or not fixed found its poses: a retry would only draw other hypotheses, and an
  // "ok" among them would lack the competitor the first try saw (on the simulated gate, seed 2,
  // the multi-view part onto the proxy: its 180° twin, refused at t 2.5 against the right
  // pose, became a wrong "ok" 5.9 m off on the retry, where the right pose came out worse).
  if (first.status != "failed" || !past_normals || first.best_pose_fits ||
      (!options.source_viewpoints.empty() && !options.target_viewpoints.empty())) {
    return first;
  }
  const auto estimated = [&](const io::PointCloud& cloud, const std::vector<Eigen::Vector3d>& sensors) {
    return sensors.empty() && !(options.use_existing_normals && cloud.has_normals());
  };
  const bool any_estimated =
      estimated(source, options.source_viewpoints) || estimated(target, options.target_viewpoints);
  // One stage per try that did not give the result, so runtime_seconds counts every try.
  const auto as_stage = [](const std::string& name, const CloudRegistrationResult& r) {
    StageTime t{name, 0.0, 0.0};
    for (const StageTime& s : r.runtime) {
      t.seconds += s.seconds;
      t.cpu_seconds += s.cpu_seconds;
    }
    return t;
  };
  CloudRegistrationOptions retry_options = options;
  std::vector<StageTime> tries = {as_stage("first try (normals towards the origin)", first)};
  for (const bool turn : {true, false}) {
    if (!turn && !any_estimated) break;
    const std::string what = any_estimated
                                 ? (turn ? "consistent normals (Hoppe et al. 1992), the source's turned"
                                         : "consistent normals (Hoppe et al. 1992)")
                                 : "the source's normals turned";
    retry_options.normal_orientation =
        turn ? NormalOrientation::kConsistentTurned : NormalOrientation::kConsistent;
    CloudRegistrationResult retry = RegisterCloudsNearOrigin(
        source, target, retry_options, source_viewpoint, target_viewpoint);
    if (retry.ok()) {
      retry.notes.insert(retry.notes.begin(),
                         "registered with " + what + "; with the normals towards each "
                         "cloud's origin it failed: " + first.reason);
      retry.runtime.insert(retry.runtime.begin(), tries.begin(), tries.end());
      return retry;
    }
    first.notes.push_back("retried with " + what + ": failed too (" + retry.reason + ")");
    tries.push_back(as_stage("retry (" + what + ")", retry));
  }
  first.runtime.insert(first.runtime.end(), tries.begin() + 1, tries.end());
  return first;
}
}  // namespace

CloudRegistrationResult RegisterClouds(const io::PointCloud& source,
                                       const io::PointCloud& target,
                                       const CloudRegistrationOptions& options) {
  Eigen::Vector3d o_t = io::MedianCentre(target.points);
  Eigen::Vector3d o_s = options.search_window_m > 0.0 ? o_t : io::MedianCentre(source.points);
  if (!o_t.allFinite() || !o_s.allFinite()) o_t = o_s = Eigen::Vector3d::Zero();  // NaN: fails
  CloudRegistrationOptions local = options;
  for (Eigen::Vector3d& v : local.source_viewpoints) v -= o_s;
  for (Eigen::Vector3d& v : local.target_viewpoints) v -= o_t;
  const auto viewpoint = [&](const io::PointCloud& cloud, const Eigen::Vector3d& o) {
    return io::LocalOrigin(cloud.points).isZero() ? Eigen::Vector3d(-o)
                                                  : GridViewpoint(cloud, options.up);
  };
  const Eigen::Vector3d v_s = viewpoint(source, o_s);
  const Eigen::Vector3d v_t = viewpoint(target, o_t);
  CloudRegistrationResult result = RegisterCloudsNearOriginRetrying(
      Shifted(source, -o_s), Shifted(target, -o_t), local, v_s, v_t);
  const auto back = [&](const Eigen::Matrix4d& t) {
    Eigen::Matrix4d out = t;
    out.topRightCorner<3, 1>() = t.topRightCorner<3, 1>() + o_t - t.topLeftCorner<3, 3>() * o_s;
    return out;
  };
  result.target_from_source = back(result.target_from_source);
  for (RegistrationHypothesis& h : result.hypotheses) {
    h.target_from_source = back(h.target_from_source);
  }
  result.covariance_centre += o_t;
  // A failure with a cloud of a few points (above the hard minimum of 10) is most likely that:
  // say so, rather than leave only the symptom ("do not overlap", "not resolved").
  const size_t fewest = std::min(source.size(), target.size());
  if (!result.ok() && fewest >= 10 && fewest < kFewPointsForDescriptors) {
    std::ostringstream hint;
    hint << "; the " << (source.size() <= target.size() ? "source" : "target") << " has only " << fewest
         << " points: too few for local descriptors (a few dozen at least in each cloud)";
    result.reason += hint.str();
  }
  // Levelled clouds were assumed (--gravity-aligned): the hypotheses turn about `up` only, but
  // the fine ICP is free, so a pose that tilts the source says the assumption did not hold.
  if (options.gravity_aligned && result.ok()) {
    const Eigen::Vector3d up = options.up.normalized();
    const double tilt = std::acos(std::clamp(
        (result.target_from_source.topLeftCorner<3, 3>() * up).normalized().dot(up), -1.0, 1.0));
    if (tilt > kLevelledTiltNote) {
      std::ostringstream note;
      note << std::setprecision(3) << "--gravity-aligned: the pose tilts the source by "
           << tilt * 180.0 / M_PI << " deg against --up; the clouds were not both levelled "
           << "about that axis (the result was found all the same)";
      result.notes.push_back(note.str());
    }
  }
  return result;
}

}  // namespace mmba::registration
