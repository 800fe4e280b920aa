#include "mmba/core/atomic_file.h"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <fstream>
#include <stdexcept>
#include <system_error>

namespace mmba {
namespace fs = std::filesystem;
namespace {

constexpr const char* kTemporaryInfix = ".tmp-";

fs::path Temporary(const fs::path& path) {
  fs::path tmp = path;
  tmp += kTemporaryInfix + std::to_string(::getpid());
  return tmp;
}

// True when no process `pid` runs (EPERM: it runs under another user).
bool ProcessGone(const std::string& digits) {
  if (digits.empty() || digits.size() > 9 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
    return false;
  }
  const pid_t pid = static_cast<pid_t>(std::stol(digits));
  return pid > 0 && pid != ::getpid() && ::kill(pid, 0) != 0 && errno == ESRCH;
}

// Removes "<name>.tmp-<pid>" beside `path` left by a process that is gone.
void RemoveStaleTemporaries(const fs::path& path) {
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  const std::string prefix = path.filename().string() + kTemporaryInfix;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0 || !ProcessGone(name.substr(prefix.size()))) continue;
    std::error_code ignored;
    fs::remove(it->path(), ignored);
  }
}

void RemoveIfThere(const fs::path& path) {
  std::error_code ec;
  fs::remove(path, ec);
  if (ec) throw std::runtime_error("cannot remove '" + path.string() + "': " + ec.message());
}

}  // namespace

void AtomicFileSet::Add(const fs::path& path, Writer writer, bool binary) {
  entries_.push_back({path, std::move(writer), binary});
}

void AtomicFileSet::Remove(const fs::path& path) { removals_.push_back(path); }

void AtomicFileSet::Commit() {
  std::vector<fs::path> temporaries;
  auto remove_temporaries = [&temporaries] {
    for (const auto& tmp : temporaries) {
      std::error_code ec;
      fs::remove(tmp, ec);
    }
  };
  try {
    for (const Entry& entry : entries_) {
      if (entry.path.has_parent_path()) fs::create_directories(entry.path.parent_path());
      RemoveStaleTemporaries(entry.path);
      const fs::path tmp = Temporary(entry.path);
      temporaries.push_back(tmp);
      std::ofstream out(tmp, entry.binary ? std::ios::binary | std::ios::trunc
                                          : std::ios::out | std::ios::trunc);
      if (!out) throw std::runtime_error("cannot open '" + tmp.string() + "' for writing");
      entry.writer(out);
      out.flush();
      if (!out) throw std::runtime_error("write to '" + tmp.string() + "' failed");
    }
    // The index (entry 0) goes last; with partners, its old version goes first.
    if (!entries_.empty() && entries_.size() + removals_.size() > 1) RemoveIfThere(entries_[0].path);
    for (size_t i = 1; i < entries_.size(); ++i) fs::rename(temporaries[i], entries_[i].path);
    for (const fs::path& path : removals_) RemoveIfThere(path);
    if (!entries_.empty()) fs::rename(temporaries[0], entries_[0].path);
  } catch (...) {
    remove_temporaries();
    throw;
  }
}

void WriteFileAtomically(const fs::path& path, const AtomicFileSet::Writer& writer,
                         bool binary) {
  AtomicFileSet set;
  set.Add(path, writer, binary);
  set.Commit();
}

}  // namespace mmba
