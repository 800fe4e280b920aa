#pragma once

#include <filesystem>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace mmba {

/// Writes one or several files so that a reader never sees a half-written result:
/// every file is written to "<name>.tmp-<pid>" in its destination directory, and only
/// when all writers succeeded are they renamed into place. If a writer throws, the
/// temporaries are removed and the exception propagates; existing files stay untouched.
class AtomicFileSet {
 public:
  using Writer = std::function<void(std::ostream&)>;

  /// Adds a file; `binary` opens it in binary mode.
  void Add(const std::filesystem::path& path, Writer writer, bool binary = false);

  /// Writes all temporaries, then renames them. Creates missing parent directories.
  /// Throws std::runtime_error naming the file when the disk refuses.
  void Commit();

 private:
  struct Entry {
    std::filesystem::path path;
    Writer writer;
    bool binary;
  };
  std::vector<Entry> entries_;
};

/// Convenience: one file, atomically.
void WriteFileAtomically(const std::filesystem::path& path,
                         const AtomicFileSet::Writer& writer, bool binary = false);

}  // namespace mmba
