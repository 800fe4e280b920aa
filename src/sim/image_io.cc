// The one translation unit of mmba_sim that includes OpenCV.
#include <opencv2/core.hpp>

#include "codecs/image_codecs.h"
#include "mmba/core/atomic_file.h"
#include "mmba/core/error.h"
#include "mmba/sim/render.h"

namespace mmba::sim {

void WritePng(const GrayImage& image, const std::string& path) {
  const cv::Mat mat(image.height, image.width, CV_8UC1, const_cast<uint8_t*>(image.pixels.data()));
  std::vector<uint8_t> buffer;
  if (!codecs::EncodeImage(".png", mat, &buffer)) {
    throw std::runtime_error("PNG encoding failed for " + path);
  }
  WriteFileAtomically(path, [&](std::ostream& out) {
    out.write(reinterpret_cast<const char*>(buffer.data()), static_cast<std::streamsize>(buffer.size()));
  }, true);
}

GrayImage ReadGray(const std::string& path) {
  const cv::Mat mat = codecs::ReadImage(path, cv::IMREAD_GRAYSCALE);
  if (mat.empty()) throw InputError::Message(path, "not a readable image (expected PNG or JPEG)");
  GrayImage image;
  image.width = mat.cols;
  image.height = mat.rows;
  image.pixels.resize(static_cast<size_t>(mat.cols) * mat.rows);
  for (int y = 0; y < mat.rows; ++y) {
    std::copy(mat.ptr<uint8_t>(y), mat.ptr<uint8_t>(y) + mat.cols,
              image.pixels.begin() + static_cast<size_t>(y) * mat.cols);
  }
  return image;
}

}  // namespace mmba::sim
