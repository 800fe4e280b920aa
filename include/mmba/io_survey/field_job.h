#pragma once

// A total-station field file read, reduced and turned into a survey network, as `mmba
// survey --input job.gsi` does it (every caller shares this policy).

#include <string>
#include <vector>

#include "mmba/survey/face_reduction.h"
#include "mmba/survey/field_book.h"
#include "mmba/survey/network.h"

namespace mmba::io {

struct FieldJob {
  survey::FieldBook book;
  std::vector<survey::KnownPoint> known;  ///< from the --known files, in order
  survey::FaceReduction reduction;
  survey::SurveyNetwork network;
};

/// True when `path` is a field file this library reads (.gsi, any case).
bool IsFieldFile(const std::string& path);

/// Reads the field file `path` (GSI), the known coordinates of `known_paths` (GSI or CSV; a
/// point in more than one keeps its first), reduces the faces and builds the network
/// (survey::BuildFieldNetwork). Throws InputError on bad input or options.
FieldJob ReadFieldJob(const std::string& path, const std::vector<std::string>& known_paths,
                      const survey::FaceReductionOptions& options);

}  // namespace mmba::io
