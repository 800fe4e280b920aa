// libFuzzer harness of the project file of `mmba adjust` (adjust::LoadProject): the input is
// project.yaml, in a folder that also holds the files and folders the seed corpus names
// (LoadProject checks that they exist, it does not read them).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include "fuzz_input.h"
#include "mmba/io_project/project.h"

namespace {

// The files and folders beside project.yaml that the seeds (make_corpus.py) refer to, made
// once per process.
void MakeProjectFolderOnce() {
  static const bool made = [] {
    for (const char* folder : {"images", "model"}) {
      std::filesystem::create_directories(mmba::fuzz::WorkDir() / "project" / folder);
    }
    for (const char* file : {"camera.yaml", "control.csv", "network.xml", "gnss.csv", "lidar.ply",
                             "scan_1.ply", "mobile.ply", "trajectory.csv", "mount.yaml",
                             "spherical.yaml", "stations.csv", "observations.csv", "rig.yaml",
                             "frames.csv"}) {
      mmba::fuzz::WriteInput(std::string("project/") + file, std::string_view("\n"));
    }
    return true;
  }();
  (void)made;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  MakeProjectFolderOnce();
  const std::string path = mmba::fuzz::WriteInput("project/project.yaml", data, size);
  mmba::fuzz::ExpectOnlyInputError([&] { mmba::adjust::LoadProject(path); });
  return 0;
}
