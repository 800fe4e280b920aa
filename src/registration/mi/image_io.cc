// The only place besides probe_plot.cc where OpenCV is used by mmba_registration_mi.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "codecs/image_codecs.h"
#include "mmba/core/atomic_file.h"
#include "mmba/core/error.h"
#include "mmba/registration/mi/image.h"
#include "mmba/registration/mi/lidar_image.h"

namespace mmba::registration::mi {

GrayImage ReadGrayImage(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw InputError::Message(path, "image file not found");
  }
  cv::Mat image;
  try {
    // Any depth: IMREAD_GRAYSCALE alone divides a 16-bit image by 256, which leaves a 12-bit
    // camera's values (0..4095 in 16 bits) 16 grey levels.
    image = codecs::ReadImage(path, cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH);
  } catch (const cv::Exception& e) {
    throw InputError::Message(path, std::string("cannot decode image: ") + e.what());
  }
  if (image.empty()) {
    throw InputError::Message(path, "cannot decode image (expected PNG, JPEG, TIFF, ...)");
  }
  GrayImage gray(image.cols, image.rows);
  if (image.depth() == CV_8U) {
    for (int r = 0; r < image.rows; ++r) {
      const uint8_t* row = image.ptr<uint8_t>(r);
      for (int c = 0; c < image.cols; ++c) gray.at(c, r) = row[c];
    }
    return gray;
  }
  // Deeper images onto the 0..255 the metric bins, as fractions (no rounding), by the sensor's
  // range rather than the image's content, so that black stays black and saturated saturated
  // (the contrast check): integers by the fewest of 8, 10, 12, 14 or 16 bits that hold the
  // largest value; floating point as 0..1 when its largest value is at most 1, else 0..max.
  cv::Mat values;
  image.convertTo(values, CV_64F);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int r = 0; r < values.rows; ++r) {
    double* row = values.ptr<double>(r);
    for (int c = 0; c < values.cols; ++c) {
      if (std::isnan(row[c])) row[c] = 0.0;  // no value: black
      lo = std::min(lo, row[c]);
      hi = std::max(hi, row[c]);
    }
  }
  if (!std::isfinite(lo) || !std::isfinite(hi) || lo < 0.0) {
    throw InputError::Message(path, "image values outside [0, inf) (smallest " +
                                        std::to_string(lo) + ", largest " + std::to_string(hi) +
                                        "): expected a non-negative grey level");
  }
  double full = 1.0;
  if (image.depth() == CV_32F || image.depth() == CV_64F) {
    full = hi <= 1.0 ? 1.0 : hi;
  } else {
    for (int bits : {8, 10, 12, 14, 16, 32}) {
      full = std::ldexp(1.0, bits) - 1.0;
      if (hi <= full) break;
    }
  }
  const double scale = 255.0 / full;
  for (int r = 0; r < image.rows; ++r) {
    const double* row = values.ptr<double>(r);
    for (int c = 0; c < image.cols; ++c) gray.at(c, r) = static_cast<float>(row[c] * scale);
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
  codecs::EncodeImage(".png", mat, &buffer);
  WriteFileAtomically(
      path,
      [&](std::ostream& out) {
        out.write(reinterpret_cast<const char*>(buffer.data()),
                  static_cast<std::streamsize>(buffer.size()));
      },
      true);
}

std::vector<uint8_t> EncodeRangeOverlayPng(const GrayImage& photo,
                                           const std::vector<const LidarImage*>& panels,
                                           const std::vector<std::string>& labels) {
  std::vector<float> ranges;
  for (const LidarImage* p : panels) {
    if (p->width != photo.width || p->height != photo.height) {
      throw std::invalid_argument("overlay: a LiDAR image is not the photo's size");
    }
    for (float d : p->depth) {
      if (std::isfinite(d) && d > 0) ranges.push_back(d);
    }
  }
  double near = 1.0, far = 2.0;
  if (!ranges.empty()) {
    std::sort(ranges.begin(), ranges.end());
    near = ranges[ranges.size() / 50];
    far = std::max(near * 1.01, static_cast<double>(ranges[ranges.size() - 1 - ranges.size() / 50]));
  }
  cv::Mat lut(1, 256, CV_8UC1);
  for (int i = 0; i < 256; ++i) lut.at<uint8_t>(0, i) = static_cast<uint8_t>(i);
  cv::Mat jet;
  cv::applyColorMap(lut, jet, cv::COLORMAP_JET);  // 0 blue … 255 red
  const int w = photo.width, h = photo.height;
  cv::Mat out(h * static_cast<int>(panels.size()), w, CV_8UC3);
  for (size_t k = 0; k < panels.size(); ++k) {
    const LidarImage& lidar = *panels[k];
    for (int r = 0; r < h; ++r) {
      cv::Vec3b* row = out.ptr<cv::Vec3b>(static_cast<int>(k) * h + r);
      for (int c = 0; c < w; ++c) {
        const uint8_t g = cv::saturate_cast<uint8_t>(photo.at(c, r));
        cv::Vec3b px(g, g, g);
        const float d = lidar.depth[static_cast<size_t>(r) * w + c];
        if (std::isfinite(d) && d > 0) {
          const double t = std::clamp((std::log(d) - std::log(near)) / (std::log(far) - std::log(near)), 0.0, 1.0);
          const cv::Vec3b colour = jet.at<cv::Vec3b>(0, static_cast<int>(std::lround(255.0 * (1.0 - t))));
          for (int ch = 0; ch < 3; ++ch) px[ch] = cv::saturate_cast<uint8_t>(0.3 * px[ch] + 0.7 * colour[ch]);
        }
        row[c] = px;
      }
    }
    if (k < labels.size()) {
      const cv::Point at(6, static_cast<int>(k) * h + 20);
      cv::putText(out, labels[k], at, cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0), 3);
      cv::putText(out, labels[k], at, cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(255, 255, 255), 1);
    }
  }
  std::vector<uint8_t> png;
  codecs::EncodeImage(".png", out, &png);
  return png;
}

}  // namespace mmba::registration::mi
