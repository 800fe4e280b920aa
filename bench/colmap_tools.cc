// Helpers for comparing `mmba ba` with `colmap bundle_adjuster` (bench/colmap_ba_compare.sh).
//   colmap_tools perturb IN_MODEL OUT_MODEL SIGMA_ROT_RAD SIGMA_T SIGMA_POINT SEED
//       a copy of a COLMAP model with Gaussian noise on poses and points (same format)
//   colmap_tools rms MODEL
//       prints "rms_px mean_px observations" of the model's reprojection errors
#include <cstdio>
#include <random>
#include <string>

#include <Eigen/Geometry>

#include "mmba/io/colmap_model.h"

int main(int argc, char** argv) {
  using namespace mmba;
  if (argc >= 3 && std::string(argv[1]) == "rms") {
    const io::ColmapModel model = io::ReadColmapModel(argv[2]);
    double sum_sq = 0.0, sum = 0.0;
    size_t n = 0;
    for (const auto& [id, point] : model.points3D) {
      for (const auto& element : point.track) {
        const io::ColmapImage& image = model.images.at(element.image_id);
        const auto xy = model.cameras.at(image.camera_id)
                            .ImgFromCam(image.cam_from_world.rotation.normalized() * point.xyz +
                                        image.cam_from_world.translation);
        if (!xy) continue;
        const double e = (*xy - image.points2D[element.point2D_idx]).norm();
        sum_sq += e * e;
        sum += e;
        ++n;
      }
    }
    std::printf("%.6f %.6f %zu\n", std::sqrt(sum_sq / n), sum / n, n);
    return 0;
  }
  if (argc == 8 && std::string(argv[1]) == "perturb") {
    io::ColmapFormat format;
    io::ColmapModel model = io::ReadColmapModel(argv[2], &format);
    const double sigma_rot = std::stod(argv[4]), sigma_t = std::stod(argv[5]),
                 sigma_point = std::stod(argv[6]);
    std::mt19937 rng(std::stoi(argv[7]));
    std::normal_distribution<double> n(0.0, 1.0);
    for (auto& [id, image] : model.images) {
      const Eigen::Vector3d w(n(rng), n(rng), n(rng));
      image.cam_from_world.rotation =
          (Eigen::Quaterniond(Eigen::AngleAxisd(sigma_rot * w.norm(), w.normalized())) *
           image.cam_from_world.rotation.normalized()).normalized();
      image.cam_from_world.translation += sigma_t * Eigen::Vector3d(n(rng), n(rng), n(rng));
    }
    for (auto& [id, point] : model.points3D) {
      point.xyz += sigma_point * Eigen::Vector3d(n(rng), n(rng), n(rng));
    }
    io::WriteColmapModel(model, argv[3], format);
    return 0;
  }
  std::fprintf(stderr, "usage: colmap_tools rms MODEL | perturb IN OUT ROT T POINT SEED\n");
  return 2;
}
