#pragma once

// cv::imread and cv::imencode without linking libopencv_imgcodecs: the codecs (and the ~140
// shared libraries behind them, GDAL's among them) are loaded with dlopen when the first
// image is read or written, so the commands that read none (register-cloud, ba, bal, ...)
// start without them. The calls behave as OpenCV's: cv::Exception passes through.

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>  // the cv::IMREAD_* flags only: nothing of it is linked

namespace mmba::codecs {

/// cv::imread(path, flags) (cv::IMREAD_*): an empty matrix when the file cannot be decoded.
cv::Mat ReadImage(const std::string& path, int flags);

/// cv::imencode(ext, image, out), e.g. ext ".png": false when it cannot encode.
bool EncodeImage(const std::string& ext, const cv::Mat& image, std::vector<uint8_t>* out);

}  // namespace mmba::codecs
