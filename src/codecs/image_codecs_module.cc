// The loadable module behind codecs/image_codecs.h: the only code linking libopencv_imgcodecs.
// C linkage, so the loader finds the functions by plain names; the arguments are C++ objects
// (one compiler, one libstdc++, one libopencv_core for both sides).
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

extern "C" {

__attribute__((visibility("default"))) void mmba_codecs_imread(const std::string* path,
                                                                int flags, cv::Mat* out) {
  *out = cv::imread(*path, flags);
}

__attribute__((visibility("default"))) bool mmba_codecs_imencode(const std::string* ext,
                                                                  const cv::Mat* image,
                                                                  std::vector<uint8_t>* out) {
  return cv::imencode(*ext, *image, *out);
}

}  // extern "C"
