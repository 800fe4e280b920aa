// Scene files of `mmba simulate --scene FILE.yaml` (schema in docs/commands/simulate.md).
#include <filesystem>

#include "mmba/core/error.h"
#include "mmba/io/yaml_reader.h"
#include "mmba/sim/simulate.h"

namespace mmba::sim {
namespace fs = std::filesystem;

void ReadSceneFile(const std::string& path, SimulateOptions* o) {
  const io::YamlReader r(path);
  const YAML::Node root = r.Load("scene file");
  using Node = const YAML::Node&;
  using F = const std::string&;
  const auto num = [&](double* v) { return [&r, v](Node n, F f) { *v = r.Number(n, f); }; };
  const auto integer = [&](int* v) { return [&r, v](Node n, F f) { *v = r.Integer(n, f); }; };
  // The preset sets sizes first; the other keys then override it, whatever their order.
  if (root.IsMap() && root["preset"]) {
    const std::string preset = r.String(root["preset"], "preset");
    if (!o->ApplyPreset(preset)) r.Fail(root["preset"], "preset", "small, full or drive", preset);
  }
  r.Map(root, "", {
      {"scene", [&](Node n, F f) {
         o->scene = r.String(n, f);
         if (o->scene != "gate" && o->scene != "cathedral") {
           r.Fail(n, f, "gate or cathedral (or give 'mesh')", o->scene);
         }
       }},
      {"mesh", [&](Node n, F f) {
         const fs::path mesh = r.String(n, f);
         o->mesh_path = (mesh.is_absolute() ? mesh : fs::path(path).parent_path() / mesh).string();
         o->scene = o->mesh_path;
       }},
      {"seed", [&](Node n, F f) {
         const int seed = r.Integer(n, f);
         if (seed < 0) r.Fail(n, f, "a seed >= 0", std::to_string(seed));
         o->seed = static_cast<uint64_t>(seed);
       }},
      {"preset", [&](Node, F) {}},  // applied above
      {"origin", [&](Node n, F f) {
         r.Map(n, f, {{"latitude_deg", num(&o->origin.latitude_deg)},
                      {"longitude_deg", num(&o->origin.longitude_deg)},
                      {"height_m", num(&o->origin.height_m)}});
       }},
      {"gate", [&](Node n, F f) {
         r.Map(n, f, {{"width_m", num(&o->gate.width_m)}, {"height_m", num(&o->gate.height_m)},
                      {"post_width_m", num(&o->gate.post_width_m)},
                      {"relief_depth_m", num(&o->gate.relief_depth_m)},
                      {"relief_blocks", integer(&o->gate.relief_blocks)},
                      {"studio_half_size_m", num(&o->gate.studio_half_size_m)}});
       }},
      {"cathedral", [&](Node n, F f) {
         r.Map(n, f, {{"width_m", num(&o->cathedral.width_m)}, {"height_m", num(&o->cathedral.height_m)},
                      {"depth_m", num(&o->cathedral.depth_m)}, {"bays", integer(&o->cathedral.bays)},
                      {"storeys", integer(&o->cathedral.storeys)},
                      {"relief_blocks", integer(&o->cathedral.relief_blocks)},
                      {"ground_half_size_m", num(&o->cathedral.ground_half_size_m)}});
       }},
      {"photos", [&](Node n, F f) {
         r.Map(n, f, {{"count", integer(&o->photos.count)}, {"width", integer(&o->photos.width)},
                      {"height", integer(&o->photos.height)}, {"focal_px", num(&o->photos.focal_px)},
                      {"tie_points", integer(&o->photos.tie_points)},
                      {"observation_sigma_px", num(&o->photos.observation_sigma_px)}});
       }},
      {"spheres", [&](Node n, F f) {
         r.Map(n, f, {{"stations", integer(&o->spheres.stations)}, {"width", integer(&o->spheres.width)},
                      {"baseline_m", num(&o->spheres.baseline_m)},
                      {"lower_height_m", num(&o->spheres.lower_height_m)},
                      {"principal_offset_px", num(&o->spheres.principal_offset_px)},
                      {"axis_tilt_deg", num(&o->spheres.axis_tilt_deg)}});
       }},
      {"rig", [&](Node n, F f) {
         r.Map(n, f, {{"frames", integer(&o->rig.frames)}, {"width", integer(&o->rig.width)},
                      {"focal_px", num(&o->rig.focal_px)},
                      {"panorama_width", integer(&o->rig.panorama_width)}});
       }},
      {"lidar", [&](Node n, F f) {
         r.Map(n, f, {{"static_scans", integer(&o->static_scans)},
                      {"azimuth_step_deg", num(&o->static_scan.azimuth_step_deg)},
                      {"elevation_step_deg", num(&o->static_scan.elevation_step_deg)},
                      {"range_sigma_m", num(&o->static_scan.noise.range_sigma_m)},
                      {"max_range_m", num(&o->static_scan.noise.max_range_m)},
                      {"mobile_revolutions", integer(&o->mobile_revolutions)},
                      {"mobile_azimuth_step_deg", num(&o->mobile_scan.azimuth_step_deg)},
                      {"mobile_speed_mps", num(&o->mobile_speed_mps)},
                      {"mobile_drive_m", num(&o->mobile_drive_m)}});
       }},
      {"total_station", [&](Node n, F f) {
         r.Map(n, f, {{"setups", integer(&o->total_station.setups)},
                      {"direction_sigma_cc", num(&o->total_station.direction_sigma_cc)},
                      {"zenith_sigma_cc", num(&o->total_station.zenith_sigma_cc)},
                      {"distance_sigma_mm", num(&o->total_station.distance_sigma_mm)},
                      {"distance_sigma_ppm", num(&o->total_station.distance_sigma_ppm)}});
       }},
      {"render", [&](Node n, F f) {
         r.Map(n, f, {{"samples_per_axis", integer(&o->render.samples_per_axis)},
                      {"noise_sigma_dn", num(&o->render.noise_sigma_dn)},
                      {"ambient", num(&o->render.ambient)}});
       }},
      {"clouds", [&](Node n, F f) {
         r.Map(n, f, {{"surface_samples", integer(&o->clouds.surface_samples)}});
       }},
  });
  std::string error;
  if (!o->Check(&error)) throw InputError::Message(path, error);
}

}  // namespace mmba::sim
