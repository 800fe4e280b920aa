// The only place besides probe_plot.cc where OpenCV is used by mmba_registration_mi.
#include <filesystem>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "mmba/core/atomic_file.h"
#include "mmba/core/error.h"
#include "mmba/registration/mi/image.h"

namespace mmba::registration::mi {

GrayImage ReadGrayImage(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw InputError::Message(path, "image file not found");
  }
  cv::Mat image;
  try {
    image = cv::imread(path, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    throw InputError::Message(path, std::string("cannot decode image: ") + e.what());
  }
  if (image.empty()) {
    throw InputError::Message(path, "cannot decode image (expected PNG, JPEG, TIFF, ...)");
  }
  GrayImage gray(image.cols, image.rows);
  for (int r = 0; r < image.rows; ++r) {
    const uint8_t* row = image.ptr<uint8_t>(r);
    for (int c = 0; c < image.cols; ++c) gray.at(c, r) = row[c];
  }
  return gray;
}

void WriteGrayPng(const GrayImage& image, const std::string& path) {
  cv::Mat mat(image.height, image.width, CV_8UC1);
  for (int r = 0; r < image.height; ++r) {
    uint8_t* row = mat.ptr<uint8_t>(r);
    for (int c = 0; c < image.width; ++c) {
      row[c] = cv::saturate_cast<uint8_t>(image.at(c, r));
    }
  }
  std::vector<uint8_t> buffer;
  cv::imencode(".png", mat, buffer);
  WriteFileAtomically(
      path,
      [&](std::ostream& out) {
        out.write(reinterpret_cast<const char*>(buffer.data()),
                  static_cast<std::streamsize>(buffer.size()));
      },
      true);
}

}  // namespace mmba::registration::mi
