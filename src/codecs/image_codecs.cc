#include "codecs/image_codecs.h"

#include <dlfcn.h>

#include <cstdlib>
#include <mutex>
#include <stdexcept>

namespace mmba::codecs {
namespace {

using ReadFn = void (*)(const std::string*, int, cv::Mat*);
using EncodeFn = bool (*)(const std::string*, const cv::Mat*, std::vector<uint8_t>*);

struct Module {
  ReadFn read = nullptr;
  EncodeFn encode = nullptr;
};

// The module, opened once (MMBA_IMAGE_CODECS_MODULE in the environment overrides the path
// it was built at). Throws std::runtime_error naming the path when it cannot be loaded.
const Module& Load() {
  static Module module;
  static std::string error;
  static std::once_flag once;
  std::call_once(once, [] {
    const char* env = std::getenv("MMBA_IMAGE_CODECS_MODULE");
    const std::string path = env != nullptr && *env != '\0' ? env : MMBA_IMAGE_CODECS_MODULE;
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      const char* why = dlerror();
      error = "cannot load the image codecs module " + path + ": " + (why ? why : "unknown");
      return;
    }
    module.read = reinterpret_cast<ReadFn>(dlsym(handle, "mmba_codecs_imread"));
    module.encode = reinterpret_cast<EncodeFn>(dlsym(handle, "mmba_codecs_imencode"));
    if (module.read == nullptr || module.encode == nullptr) {
      error = "the image codecs module " + path + " lacks mmba_codecs_imread/imencode";
    }
  });
  if (!error.empty()) throw std::runtime_error(error);
  return module;
}

}  // namespace

cv::Mat ReadImage(const std::string& path, int flags) {
  cv::Mat out;
  Load().read(&path, flags, &out);
  return out;
}

bool EncodeImage(const std::string& ext, const cv::Mat& image, std::vector<uint8_t>* out) {
  return Load().encode(&ext, &image, out);
}

}  // namespace mmba::codecs
