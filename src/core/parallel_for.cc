#include "mmba/core/parallel_for.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace mmba {

namespace {

// On the threads of a running ParallelFor (the caller's included): the number of its workers
// still taking items, and how many it started; nullptr outside a loop.
thread_local std::atomic<int>* t_loop_busy = nullptr;
thread_local int t_loop_threads = 0;

// Keeps the first exception of several threads.
class FirstError {
 public:
  void Keep(std::exception_ptr error) {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (!error_) error_ = std::move(error);
  }
  void Rethrow() const {
    if (error_) std::rethrow_exception(error_);
  }

 private:
  std::mutex mutex_;
  std::exception_ptr error_;
};

}  // namespace

bool CoreFreeForSplit() { return t_loop_busy == nullptr || t_loop_busy->load() < t_loop_threads; }

void ParallelFor(int count, int threads, const std::function<void(int)>& body) {
  threads = std::max(1, std::min(threads, count));
  if (threads == 1) {
    for (int i = 0; i < count; ++i) body(i);
    return;
  }
  std::atomic<int> next{0};
  std::atomic<int> busy{threads};
  FirstError error;
  auto worker = [&] {
    std::atomic<int>* const outer_busy = t_loop_busy;
    const int outer_threads = t_loop_threads;
    t_loop_busy = &busy;
    t_loop_threads = threads;
    try {
      for (int i = next++; i < count; i = next++) body(i);
    } catch (...) {
      error.Keep(std::current_exception());
      next = count;  // the items not yet taken are skipped
    }
    --busy;  // no more items for this worker
    t_loop_busy = outer_busy;
    t_loop_threads = outer_threads;
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& thread : pool) thread.join();
  error.Rethrow();
}

void ParallelChunks(size_t n, int threads, const std::function<void(size_t, size_t)>& fn) {
  const size_t t = static_cast<size_t>(std::max(1, threads));
  if (t == 1 || n < 2 * t) {
    fn(0, n);
    return;
  }
  const size_t chunk = (n + t - 1) / t;
  const int chunks = static_cast<int>((n + chunk - 1) / chunk);
  ParallelFor(chunks, chunks, [&](int i) {
    const size_t begin = static_cast<size_t>(i) * chunk;
    fn(begin, std::min(n, begin + chunk));
  });
}

void OnThreads(int threads, const std::function<void(int, int)>& fn) {
  threads = std::max(1, threads);
  ParallelFor(threads, threads, [&](int t) { fn(t, threads); });
}

}  // namespace mmba
