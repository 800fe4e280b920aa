#include "mmba/registration/mi/mi_registration.h"

#include <glog/logging.h>

namespace mmba::registration::mi {

View CropView(const View& view, int col0, int col1) {
  CHECK(0 <= col0 && col0 < col1 && col1 <= view.image.width) << "crop columns out of range";
  View crop;
  crop.name = view.name + "[" + std::to_string(col0) + ":" + std::to_string(col1) + "]";
  crop.view_from_cam = view.view_from_cam;
  crop.view_from_cam_t = view.view_from_cam_t;
  crop.image_pixels_per_pixel = view.image_pixels_per_pixel;
  crop.image_camera = view.image_camera;
  crop.image = GrayImage(col1 - col0, view.image.height);
  for (int r = 0; r < view.image.height; ++r) {
    for (int c = col0; c < col1; ++c) crop.image.at(c - col0, r) = view.image.at(c, r);
  }
  crop.camera = view.camera;
  crop.camera.width = col1 - col0;
  const std::vector<int> principal = sensors::CameraModelPrincipalIdxs(view.camera.model_id);
  CHECK(!principal.empty()) << "camera model without a principal point";
  crop.camera.params[principal[0]] -= col0;
  return crop;
}

std::array<std::vector<Frame>, 2> SplitIntoHalves(const std::vector<Frame>& frames,
                                                  std::string* kind) {
  std::array<std::vector<Frame>, 2> halves;
  size_t total = 0, with_views = 0;
  for (const Frame& frame : frames) {
    total += frame.views.size();
    with_views += frame.views.empty() ? 0 : 1;
  }
  if (with_views >= 2) {
    // Several frames sharing one pose (the rig calibration): whole frames alternately. What
    // differs between frames — their scene, the LiDAR's georeferencing over each frame's
    // time window — is what must agree; halves that each hold part of every frame share it.
    size_t index = 0;
    for (const Frame& frame : frames) {
      if (!frame.views.empty()) halves[index++ % 2].push_back(frame);
    }
    if (kind != nullptr) *kind = "frames";
  } else if (total >= 2) {
    size_t index = 0;
    for (const Frame& frame : frames) {
      std::array<Frame, 2> parts;
      for (int h = 0; h < 2; ++h) {
        parts[h].name = frame.name;
        parts[h].points = frame.points;
      }
      for (const View& view : frame.views) parts[index++ % 2].views.push_back(view);
      for (int h = 0; h < 2; ++h) {
        if (!parts[h].views.empty()) halves[h].push_back(std::move(parts[h]));
      }
    }
    if (kind != nullptr) *kind = "views";
  } else if (total == 1) {
    for (const Frame& frame : frames) {
      if (frame.views.empty()) continue;
      const View& view = frame.views.front();
      if (view.image.width < 16) break;  // too narrow to halve: the check is not applicable
      const int middle = view.image.width / 2;
      for (int h = 0; h < 2; ++h) {
        Frame part;
        part.name = frame.name;
        part.points = frame.points;
        part.views.push_back(h == 0 ? CropView(view, 0, middle)
                                    : CropView(view, middle, view.image.width));
        halves[h].push_back(std::move(part));
      }
    }
    if (kind != nullptr) *kind = "left/right halves";
  }
  return halves;
}

}  // namespace mmba::registration::mi
