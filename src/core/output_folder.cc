#include "mmba/core/output_folder.h"

#include <fcntl.h>
#include <stdio.h>  // renameat2, RENAME_EXCHANGE
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include "mmba/core/error.h"

namespace mmba {
namespace {

namespace fs = std::filesystem;

constexpr const char* kStagingInfix = ".mmba-staging-";
constexpr const char* kLockSuffix = ".mmba-lock";
constexpr const char* kWhatToGive = "give a new or empty folder, or one mmba wrote";

// Absolute, normalised, symlinks of the existing part resolved, no trailing separator.
fs::path Resolve(const std::string& path) {
  std::error_code ec;
  fs::path absolute = fs::absolute(path, ec);
  if (ec) absolute = fs::path(path);
  fs::path resolved = fs::weakly_canonical(absolute, ec);
  if (ec) resolved = absolute.lexically_normal();
  if (resolved.filename().empty() && resolved != resolved.root_path()) resolved = resolved.parent_path();
  return resolved;
}

// True when `inner` is `outer` or lies inside it (whole path components).
bool IsWithin(const fs::path& inner, const fs::path& outer) {
  auto i = inner.begin();
  for (auto o = outer.begin(); o != outer.end(); ++o, ++i) {
    if (o->empty()) continue;
    if (i == inner.end() || *i != *o) return false;
  }
  return true;
}

std::string SystemError() { return std::strerror(errno); }

}  // namespace

bool OutputFolder::HoldsMarker(const fs::path& folder) {
  std::error_code ec;
  return fs::is_regular_file(fs::symlink_status(folder / kMarkerName, ec));
}

OutputFolder::OutputFolder(const std::string& path, const std::string& option, const std::string& writer,
                           const std::vector<NamedPath>& inputs)
    : option_(option), writer_(writer), path_(Resolve(path)) {
  const auto fail = [&](const std::string& why) {
    throw InputError::Message(option_, "cannot write '" + path + "': " + why);
  };
  if (path.empty()) fail("no folder given; expected a folder to write into (created if missing)");
  if (path_ == path_.root_path()) fail("it is the root folder; " + std::string(kWhatToGive));
  std::error_code ec;
  const fs::file_status status = fs::status(path_, ec);
  if (fs::exists(status) && !fs::is_directory(status)) {
    fail("it is an existing file, not a folder; expected a folder to write into (created if missing)");
  }
  for (const NamedPath& input : inputs) {
    if (input.path.empty()) continue;
    const fs::path resolved = Resolve(input.path);
    if (resolved == path_) {
      throw InputError::Message(option_, "'" + path + "' is the input " + input.name +
                                             "; mmba never overwrites its inputs, give another folder");
    }
    if (IsWithin(resolved, path_)) {
      throw InputError::Message(option_, "'" + path + "' holds the input " + input.name + " ('" + input.path +
                                             "'); mmba replaces its output folder whole, so it must hold no "
                                             "input: give another folder");
    }
  }
  const fs::path cwd = fs::current_path(ec);
  if (!ec && IsWithin(Resolve(cwd.string()), path_)) {
    fail("it is or holds the current folder, which mmba would replace; give another folder");
  }
  // The parent folder: the lock file and the staging folder live there.
  const fs::path parent = path_.parent_path();
  fs::path existing = parent;
  while (!fs::exists(existing, ec) && existing != existing.root_path()) {
    created_root_ = existing;
    existing = existing.parent_path();
  }
  if (!fs::is_directory(existing, ec)) fail("'" + existing.string() + "' is a file, not a folder");
  if (!created_root_.empty() && !fs::create_directories(parent, ec) && ec) {
    fail("cannot create the folder '" + parent.string() + "' (" + ec.message() + ")");
  }
  try {
    Lock();
    CheckReplaceable();
    RemoveStaleStaging();
    CreateStaging();
  } catch (...) {
    Abandon();
    throw;
  }
}

OutputFolder::~OutputFolder() { Abandon(); }

void OutputFolder::Lock() {
  lock_path_ = path_;
  lock_path_ += kLockSuffix;
  // A run that ends removes the lock file while it holds the lock; one that opened the file
  // before that removal then locks a file no longer at lock_path_ and must try again.
  for (;;) {
    const int fd = ::open(lock_path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd < 0) {
      throw InputError::Message(option_, "cannot write '" + path_.string() + "': cannot create a file in '" +
                                             path_.parent_path().string() + "' (" + SystemError() + ")");
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int error = errno;
      ::close(fd);
      if (error == EWOULDBLOCK) {
        throw InputError::Message(option_, "'" + path_.string() + "' is in use by another mmba run (it holds '" +
                                               lock_path_.string() +
                                               "'); wait for that run to end, or give another folder");
      }
      throw InputError::Message(option_, "cannot lock '" + lock_path_.string() + "' (" + std::strerror(error) + ")");
    }
    struct stat held, named;
    if (::fstat(fd, &held) == 0 && ::stat(lock_path_.c_str(), &named) == 0 && held.st_dev == named.st_dev &&
        held.st_ino == named.st_ino) {
      lock_fd_ = fd;
      return;
    }
    ::close(fd);
  }
}

void OutputFolder::CheckReplaceable() const {
  std::error_code ec;
  if (!fs::exists(path_, ec)) return;
  if (!fs::is_directory(path_, ec)) {
    throw InputError::Message(option_, "cannot write '" + path_.string() +
                                           "': it is an existing file, not a folder; expected a folder to "
                                           "write into (created if missing)");
  }
  if (HoldsMarker(path_)) return;
  size_t entries = 0;
  for (fs::directory_iterator it(path_, ec), end; !ec && it != end; it.increment(ec)) ++entries;
  if (ec) {
    throw InputError::Message(option_, "cannot read the folder '" + path_.string() + "' (" + ec.message() + ")");
  }
  if (entries == 0) return;
  throw InputError::Message(option_, "'" + path_.string() + "' is a folder mmba did not write (it holds " +
                                         std::to_string(entries) + (entries == 1 ? " entry" : " entries") +
                                         " and no " + kMarkerName +
                                         "); mmba replaces its output folder whole and never deletes what it did "
                                         "not write: " + kWhatToGive);
}

void OutputFolder::RemoveStaleStaging() const {
  const std::string prefix = path_.filename().string() + kStagingInfix;
  std::error_code ec;
  for (fs::directory_iterator it(path_.parent_path(), ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    std::error_code ignored;
    if (name.compare(0, prefix.size(), prefix) != 0 || !fs::is_directory(it->symlink_status(ignored))) continue;
    if (HoldsMarker(it->path())) {
      fs::remove_all(it->path(), ignored);
    } else {
      ::rmdir(it->path().c_str());  // only when empty: killed between mkdtemp and the marker
    }
  }
}

void OutputFolder::CreateStaging() {
  std::string name = path_.string() + kStagingInfix + "XXXXXX";
  if (::mkdtemp(name.data()) == nullptr) {
    throw InputError::Message(option_, "cannot write '" + path_.string() + "': cannot create a folder in '" +
                                           path_.parent_path().string() + "' (" + SystemError() + ")");
  }
  staging_ = name;
  std::ofstream marker(staging_ / kMarkerName);
  marker << "mmba output folder, written by " << writer_
         << ".\nmmba replaces this folder whole when it writes into it again; without this file it refuses to.\n";
  marker.close();
  if (!marker) throw std::runtime_error("cannot write '" + (staging_ / kMarkerName).string() + "'");
}

void OutputFolder::Commit() {
  if (committed_ || staging_.empty()) throw std::logic_error("OutputFolder::Commit called twice");
  CheckReplaceable();
  const auto refused = [&](const std::string& what) {
    return std::runtime_error("cannot put the result in place of '" + path_.string() + "': " + what + " (" +
                              SystemError() + "); the earlier result is unchanged");
  };
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(path_, ec))) {
    if (::rename(staging_.c_str(), path_.c_str()) != 0) throw refused("rename");
  } else if (::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, path_.c_str(), RENAME_EXCHANGE) == 0) {
    fs::remove_all(staging_, ec);  // the earlier result, now under the staging name
  } else if (errno == EINVAL || errno == ENOSYS || errno == EOPNOTSUPP) {
    // A file system without the exchange: the earlier result moves aside under a staging name
    // (a later run removes it should this one die here), then the new one moves in.
    fs::path aside = staging_;
    aside += "-earlier";
    if (::rename(path_.c_str(), aside.c_str()) != 0) throw refused("move aside");
    if (::rename(staging_.c_str(), path_.c_str()) != 0) {
      const std::runtime_error error = refused("rename");
      ::rename(aside.c_str(), path_.c_str());
      throw error;
    }
    fs::remove_all(aside, ec);
  } else {
    throw refused("exchange");
  }
  committed_ = true;
}

void OutputFolder::Abandon() noexcept {
  std::error_code ec;
  if (!committed_ && !staging_.empty()) fs::remove_all(staging_, ec);
  staging_.clear();
  if (lock_fd_ >= 0) {
    ::unlink(lock_path_.c_str());  // while holding the lock; see Lock()
    ::close(lock_fd_);
    lock_fd_ = -1;
  }
  if (!committed_ && !created_root_.empty()) {
    // The parent folders this run created, while empty, deepest first.
    for (fs::path p = path_.parent_path(); ::rmdir(p.c_str()) == 0 && p != created_root_; p = p.parent_path()) {
    }
    created_root_.clear();
  }
}

}  // namespace mmba
