#pragma once

// The folder a run writes its result into (`--output DIR`): checked before any work, locked
// for the run, written whole into a private staging folder and swapped in at the end.

#include <filesystem>
#include <string>
#include <vector>

namespace mmba {

/// An input of a run, for the output checks: the option or role that names it ("--input",
/// "the project file") and its path (a file or a folder; "" is skipped).
struct NamedPath {
  std::string name;
  std::string path;
};

/// The output folder of one run.
///
/// The rule: mmba replaces an output folder whole, so it writes only where that deletes
/// nothing it did not write. A folder is mmba's when it holds the marker file `.mmba-output`
/// (kMarkerName), which every output folder mmba writes holds. The constructor accepts a path
/// that does not exist, an empty folder and a folder holding the marker. It refuses with
/// InputError (exit 2; the option, the path and what to do), before any work and writing
/// nothing:
///  - an existing file (not a folder);
///  - a non-empty folder without the marker (a folder of user data);
///  - a folder that is an input of the run or holds one (at any depth), or holds the current
///    working folder: the swap would delete it. A folder inside an input folder is fine
///    (e.g. SCENE/registration_eval);
///  - a folder another mmba run is writing ("in use", see below).
///
/// Concurrency: from the constructor until destruction the run holds an exclusive flock on
/// the lock file "<folder>.mmba-lock" beside the folder (removed at destruction); a second run
/// into the same folder is refused at once. Paths are compared with symlinks resolved, so two
/// spellings of one folder share one lock.
///
/// Atomic result: the run writes into staging(), a private folder "<folder>.mmba-staging-XXXXXX"
/// beside the folder (holding the marker from its creation). Commit() swaps it with the folder
/// in one renameat2(RENAME_EXCHANGE) (a plain rename when there is nothing to replace), then
/// removes the earlier result: a reader sees the earlier result or the new one, whole, never a
/// mix. Durability across a power loss is left to the file system (no fsync).
///
/// Leftovers: a run that throws or returns without Commit removes its staging folder (and the
/// parent folders it created, when still empty) and leaves the earlier result untouched. A
/// run killed outright (kill -9) leaves at most a staging folder holding the marker (or an
/// earlier result moved aside under a staging name) and an unlocked lock file; the next run
/// into the same folder removes every "<folder>.mmba-staging-*" folder that holds the marker
/// or is empty (under the lock, so none of them belongs to a live run) and reuses the lock file.
class OutputFolder {
 public:
  /// The marker file's name in every output folder mmba writes.
  static constexpr const char* kMarkerName = ".mmba-output";

  /// Checks `path` against the rule, locks it and creates the staging folder (and missing
  /// parent folders). `option` names the folder in messages ("--output"); `writer` (e.g.
  /// "mmba adjust") is recorded in the marker; `inputs` are every file and folder the run reads.
  /// Throws InputError as described above.
  OutputFolder(const std::string& path, const std::string& option, const std::string& writer,
               const std::vector<NamedPath>& inputs);
  /// Removes the staging folder unless committed; releases the lock.
  ~OutputFolder();
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  /// The folder to write the result into: exists, holds the marker only at first.
  const std::filesystem::path& staging() const { return staging_; }
  /// The output folder, absolute, symlinks resolved: where the result is after Commit().
  const std::filesystem::path& path() const { return path_; }

  /// Puts the staged result in place of the folder (see above). Call once. Throws InputError
  /// when the folder no longer follows the rule (files put into it during the run), and
  /// std::runtime_error naming the folder when the file system refuses; the earlier result
  /// then stays as it was.
  void Commit();

  /// True when `folder` holds the marker (a regular file named kMarkerName).
  static bool HoldsMarker(const std::filesystem::path& folder);

 private:
  void CheckReplaceable() const;
  void Lock();
  void RemoveStaleStaging() const;
  void CreateStaging();
  void Abandon() noexcept;

  std::string option_;
  std::string writer_;
  std::filesystem::path path_;
  std::filesystem::path lock_path_;
  std::filesystem::path staging_;
  std::filesystem::path created_root_;  ///< the first parent folder this run created ("" = none)
  int lock_fd_ = -1;
  bool committed_ = false;
};

}  // namespace mmba
