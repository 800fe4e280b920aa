#pragma once

// What built this mmba: the release version (CMake's project version) and the git commit of
// the source tree it was configured from ("unknown" outside a git checkout; "-dirty" appended
// when the tree had uncommitted changes). `mmba --version` prints them and every JSON output
// records them, so a result can be traced to the code that produced it.

#include <string>

namespace mmba {

/// "0.1.0".
const char* Version();
/// Abbreviated commit hash, e.g. "3f2a9c1" or "3f2a9c1-dirty"; "unknown" without git.
const char* GitCommit();
/// "mmba 0.1.0 (commit 3f2a9c1)".
std::string VersionLine();

}  // namespace mmba

namespace mmba {

/// Records what built mmba in an output JSON object: `"mmba": {"version": …, "commit": …}`.
/// A template over nlohmann::json / ordered_json, so core needs no JSON library.
template <class Json>
void RecordBuild(Json* json) {
  (*json)["mmba"] = {{"version", Version()}, {"commit", GitCommit()}};
}

}  // namespace mmba
