// OUT.json of a prepared MI registration job (result_json.h, JobResultToJson): the result's
// fields, the settings as resolved, the clouds, a rig's cameras, several frames' statuses and
// the pixel offsets of a test start.
#include <string>

#include "mmba/io/pose_json.h"
#include "mmba/registration/mi/result_json.h"

namespace mmba::registration::mi {
namespace {

using json = nlohmann::json;

json OffsetJson(const PixelOffsetStats& s) {
  return {{"points", s.points}, {"median_px", s.median_px}, {"mean_px", s.mean_px}, {"p90_px", s.p90_px},
          {"max_px", s.max_px}};
}

// The settings a result depends on, as the user set them (request) and the job resolved them.
json SettingsJson(const JobRequest& request, const Job& job) {
  const RegistrationOptions& o = request.options;
  json settings = {{"metric", MetricName(o.metric.kind)},
                   {"representation", RepresentationName(job.options.render.representation)},
                   {"view", job.view_name},
                   {"bins", o.metric.bins},
                   {"smoothing", SmoothingName(o.metric.smoothing)},
                   {"region", job.region_note.empty() ? RegionName(o.metric.region) : "whole"},
                   {"pyramid_levels", o.pyramid_levels},
                   {"bound_m", o.bound_translation_m},
                   {"bound_deg", o.bound_rotation_deg},
                   {"pyramid_paths", o.pyramid_paths},
                   {"pyramid_paths_adaptive", o.pyramid_paths_adaptive},
                   {"whole_image_checks", o.whole_image_checks},
                   {"weak_direction_scan", o.scan_weak_direction},
                   {"all_checks", o.measure_all_checks},
                   {"point_samples", o.point_samples},
                   {"sample_block_px", o.sample_block_px},
                   {"covariance_pixel_floor", o.covariance_pixel_floor},
                   {"covariance_per_point_samples", job.options.covariance_per_point_samples},
                   {"surface_classes", request.surface_classes},
                   {"orientation_classes", job.orientation_sectors},
                   {"surface_voxel_m", request.surface_voxel_m},
                   {"incidence_correction", request.incidence_correction}};
  if (!job.region_note.empty()) settings["region_note"] = job.region_note;
  return settings;
}

// The pose is the rig's: rig_from_lidar (the correction about the rig's origin), and each
// camera's own cam_from_lidar = cam_from_rig · rig_from_lidar (null when not registered).
void AddRig(const Job& job, const RegistrationResult& result, json* out) {
  for (const char* key : {"cam_from_lidar", "cam_from_lidar_start", "failed_attempt_cam_from_lidar"}) {
    std::string renamed = key;
    renamed.replace(renamed.find("cam_from_lidar"), 14, "rig_from_lidar");
    (*out)[renamed] = (*out)[key];
    out->erase(key);
  }
  (*out)["correction_convention"] =
      "lidar_from_rig' = [Rz(yaw) Ry(pitch) Rx(roll) R | c + t] about the rig's origin, "
      "axes of the LiDAR frame; metres and degrees";
  json cameras = json::array();
  for (size_t k = 0; k < job.rig.cameras.size(); ++k) {
    bool used = false;
    for (const Frame& frame : job.frames) {
      for (const View& view : frame.views) used = used || view.name == job.rig.names[k];
    }
    cameras.push_back({{"name", job.rig.names[k]},
                       {"used", used},
                       {"cam_from_lidar", result.ok() ? io::PoseToJson(job.rig.cam_from_rig[k] * result.cam_from_lidar)
                                                      : json(nullptr)}});
  }
  (*out)["cameras"] = cameras;
}

// Each frame by its index (its order in the request's pairs, then the list file's), image and
// cloud; its status in the calibration: used, rejected (with the reason: alone it carried no
// information, or it disagreed with the others), or not used (the calibration stopped before
// the frames' agreement was tested); and its own screening registration.
void AddFrames(const Job& job, const RegistrationResult& result, json* out) {
  const auto index_of = [&](const std::string& name) {
    for (size_t i = 0; i < job.frames.size(); ++i) {
      if (job.frames[i].name == name) return static_cast<int>(i);
    }
    return -1;
  };
  (*out)["used_frames"] = result.used_frames;
  json rejected = json::array();
  for (const auto& [name, why] : result.rejected_frames) {
    const int i = index_of(name);
    rejected.push_back({{"index", i},
                        {"image", name},
                        {"lidar", i >= 0 ? json(job.paths[i].lidar) : json(nullptr)},
                        {"frame", name},
                        {"reason", why}});
  }
  (*out)["rejected_frames"] = rejected;
  json per_frame = json::array();
  for (size_t i = 0; i < result.frame_results.size(); ++i) {
    const RegistrationResult& r = result.frame_results[i];
    std::string status = "not used", reason = result.reason;
    for (const auto& [name, why] : result.rejected_frames) {
      if (name == job.frames[i].name) status = "rejected", reason = why;
    }
    for (const std::string& name : result.used_frames) {
      if (name == job.frames[i].name) status = "used", reason.clear();
    }
    per_frame.push_back({{"index", i},
                         {"image", job.paths[i].image},
                         {"lidar", job.paths[i].lidar},
                         {"frame", job.frames[i].name},
                         {"status", status},
                         {"reason", reason},
                         {"screening", {{"status", r.status}, {"reason", r.reason}}},
                         {"correction", CorrectionToJson(r.correction)}});
  }
  (*out)["frames"] = per_frame;
}

// How far the start and the result put the LiDAR points from where `reference` puts them,
// per view of the first frame.
json OffsetsAgainst(const Job& job, const Rigid3d& reference, const Rigid3d& cam_from_local) {
  json offsets = json::array();
  for (const View& view : job.frames[0].views) {
    offsets.push_back(
        {{"view", view.name},
         {"before", OffsetJson(PixelOffsets(job.clouds[0], view, reference, job.start, job.options.render))},
         {"after", OffsetJson(PixelOffsets(job.clouds[0], view, reference, cam_from_local, job.options.render))}});
  }
  return offsets;
}

}  // namespace

json JobResultToJson(const JobRequest& request, const Job& job, const RegistrationResult& result,
                     const Rigid3d& cam_from_local) {
  json out = ResultToJson(result, job.options, job.start_given);
  out["settings"] = SettingsJson(request, job);
  // Per cloud: points read, and dropped as beyond every camera's range (or not finite).
  out["clouds"] = job.clouds_json;
  // Per cloud: the fitted exponent of I = rho * cos^k (null: not corrected).
  out["incidence_correction"] = job.incidence_json;
  if (job.rig_mode) AddRig(job, result, &out);
  if (job.frames.size() > 1) AddFrames(job, result, &out);
  if (!request.perturb.empty()) {  // against the unperturbed start
    out["perturbation"] = CorrectionToJson(Eigen::Map<const Vector6d>(request.perturb.data()));
    out["pixel_offset_vs_reference"] = OffsetsAgainst(job, job.reference, cam_from_local);
  }
  if (!request.initial.empty() && job.have_calibration_pose) {
    // A start from the request's pose while the calibration file (or camera/rig YAML) holds
    // its own: the offsets against the calibration, also for a start not made by a perturbation.
    out["pixel_offset_vs_calibration"] = OffsetsAgainst(job, job.calibration, cam_from_local);
  }
  return out;
}

}  // namespace mmba::registration::mi
