#include "mmba/io_survey/field_job.h"

#include <set>

#include "mmba/core/error.h"
#include "mmba/io_survey/gsi.h"
#include "mmba/io_survey/known_points.h"
#include "mmba/survey/field_network.h"

namespace mmba::io {

bool IsFieldFile(const std::string& path) { return IsGsiPath(path); }

FieldJob ReadFieldJob(const std::string& path, const std::vector<std::string>& known_paths,
                      const survey::FaceReductionOptions& options) {
  std::string problem;
  if (!options.Check(&problem)) throw InputError::Message("--set", problem);
  FieldJob job;
  job.book = ReadGsi(path);
  std::set<std::string> ids;
  for (const std::string& known_path : known_paths) {
    for (survey::KnownPoint& p : ReadKnownPoints(known_path)) {
      if (ids.insert(p.id).second) job.known.push_back(std::move(p));
    }
  }
  job.reduction = survey::ReduceFaces(job.book, options);
  if (job.reduction.sets.empty()) {
    throw InputError::Message(path, "no observations to adjust (" + std::to_string(job.book.setups.size()) +
                                        " set-up(s), " + std::to_string(job.book.RawObservationCount()) +
                                        " measurement(s))");
  }
  job.network = survey::BuildFieldNetwork(job.reduction, job.known, options, path);
  return job;
}

}  // namespace mmba::io
