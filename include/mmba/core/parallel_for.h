#pragma once

// Loops over items on a few threads: the one thread pool idiom of mmba. The caller's thread
// works too, so `threads` = 1 runs inline with no thread started. The first exception thrown
// by a body stops the items not yet taken and is rethrown on the caller's thread.

#include <cstddef>
#include <functional>

namespace mmba {

/// body(0) .. body(count − 1), each once, on up to `threads` threads (the caller's included).
/// Items are taken in increasing order by whichever thread is free, so the order in which they
/// finish is not fixed: a body writes only its own slot of the output.
void ParallelFor(int count, int threads, const std::function<void(int)>& body);

/// fn(begin, end) over [0, n) in `threads` contiguous chunks of ⌈n / threads⌉ items (the last
/// shorter); inline as fn(0, n) when threads ≤ 1 or n < 2 · threads.
void ParallelChunks(size_t n, int threads, const std::function<void(size_t, size_t)>& fn);

/// fn(t, threads) for t = 0 .. threads − 1, each on its own thread (t = 0 on the caller's).
void OnThreads(int threads, const std::function<void(int, int)>& fn);

/// Inside a ParallelFor: true when a worker of the innermost loop has run out of items (its
/// core is free), so that one item may split its own work over two threads; true outside any
/// loop. E.g. the third of three restarts on two threads, or the longer of two halves.
bool CoreFreeForSplit();

}  // namespace mmba
