#include "codecs/image_codecs.h"

#include <spdlog/spdlog.h>

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <system_error>

namespace mmba::codecs {
namespace {

using ReadFn = void (*)(const std::string*, int, cv::Mat*);
using EncodeFn = bool (*)(const std::string*, const cv::Mat*, std::vector<uint8_t>*);

struct Module {
  ReadFn read = nullptr;
  EncodeFn encode = nullptr;
};

// Where the module is: MMBA_IMAGE_CODECS_MODULE in the environment; else, when mmba runs
// from an install tree, <prefix>/lib/mmba/ beside its bin/; else the build tree's path.
std::string ModulePath() {
  const char* env = std::getenv("MMBA_IMAGE_CODECS_MODULE");
  if (env != nullptr && *env != '\0') return env;
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = (exe.parent_path() / MMBA_IMAGE_CODECS_MODULE_FROM_BIN).lexically_normal();
    if (fs::is_regular_file(installed, ec)) return installed.string();
  }
  return MMBA_IMAGE_CODECS_MODULE;
}

// The module, opened once. Throws std::runtime_error naming the path when it cannot be loaded.
const Module& Load() {
  static Module module;
  static std::string error;
  static std::once_flag once;
  std::call_once(once, [] {
    const std::string path = ModulePath();
    spdlog::debug("image codecs: loading {}", path);
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
