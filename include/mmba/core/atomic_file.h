#pragma once

#include <filesystem>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace mmba {

/// Writes one or several files so that a reader never sees a half-written result nor a mix
/// of two results:
///  - every file is written to "<name>.tmp-<pid>" in its destination folder, and only when
///    all writers succeeded are they renamed into place. If a writer throws, the
///    temporaries are removed and the exception propagates; existing files stay untouched.
///  - The first file added is the set's index (e.g. the JSON result beside its error map).
///    With more than one file (or a Remove), Commit deletes the old index first, then puts
///    the other files in place (renames, removals), then renames the new index last. So
///    whenever the index exists, every other file of the set is from the same Commit (or,
///    for a Remove, absent); a run killed in between leaves the index missing, never a mix.
///  - A temporary "<name>.tmp-<pid>" beside a destination whose process no longer runs
///    (a run killed while writing) is removed by the next Commit writing that file.
class AtomicFileSet {
 public:
  using Writer = std::function<void(std::ostream&)>;

  /// Adds a file; `binary` opens it in binary mode.
  void Add(const std::filesystem::path& path, Writer writer, bool binary = false);

  /// The result has no file at `path` (a partner an earlier result wrote and this one does
  /// not): an existing file there is deleted by Commit, before the index is renamed.
  void Remove(const std::filesystem::path& path);

  /// Writes all temporaries, then puts them in place as described above. Creates missing
  /// parent folders. Throws std::runtime_error naming the file when the disk refuses.
  void Commit();

 private:
  struct Entry {
    std::filesystem::path path;
    Writer writer;
    bool binary;
  };
  std::vector<Entry> entries_;
  std::vector<std::filesystem::path> removals_;
};

/// Convenience: one file, atomically.
void WriteFileAtomically(const std::filesystem::path& path,
                         const AtomicFileSet::Writer& writer, bool binary = false);

}  // namespace mmba
