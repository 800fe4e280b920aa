#include "mmba/core/atomic_file.h"

#include <unistd.h>

#include <fstream>
#include <stdexcept>
#include <system_error>

namespace mmba {
namespace fs = std::filesystem;

void AtomicFileSet::Add(const fs::path& path, Writer writer, bool binary) {
  entries_.push_back({path, std::move(writer), binary});
}

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
      fs::path tmp = entry.path;
      tmp += ".tmp-" + std::to_string(::getpid());
      temporaries.push_back(tmp);
      std::ofstream out(tmp, entry.binary ? std::ios::binary | std::ios::trunc
                                          : std::ios::out | std::ios::trunc);
      if (!out) throw std::runtime_error("cannot open '" + tmp.string() + "' for writing");
      entry.writer(out);
      out.flush();
      if (!out) throw std::runtime_error("write to '" + tmp.string() + "' failed");
    }
    for (size_t i = 0; i < entries_.size(); ++i) {
      fs::rename(temporaries[i], entries_[i].path);
    }
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
