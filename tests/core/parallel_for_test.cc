#include "mmba/core/parallel_for.h"

#include <algorithm>
#include <atomic>
#include <numeric>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

namespace mmba {
namespace {

TEST(ParallelFor, RunsEveryItemOnce) {
  for (int threads : {1, 2, 3, 8}) {
    std::vector<int> hits(100, 0);
    ParallelFor(100, threads, [&](int i) { ++hits[i]; });
    EXPECT_EQ(std::accumulate(hits.begin(), hits.end(), 0), 100) << threads << " threads";
    for (int h : hits) EXPECT_EQ(h, 1);
  }
  int calls = 0;
  ParallelFor(0, 4, [&](int) { ++calls; });
  EXPECT_EQ(calls, 0);
}

TEST(ParallelFor, RethrowsTheBodysExceptionOnTheCaller) {
  std::atomic<int> done{0};
  EXPECT_THROW(ParallelFor(1000, 2,
                           [&](int i) {
                             if (i == 10) throw std::runtime_error("item 10");
                             ++done;
                           }),
               std::runtime_error);
  EXPECT_LT(done.load(), 999);  // the items after the error were skipped
}

TEST(ParallelFor, CoreFreeForSplitWhenAWorkerHasNoMoreItems) {
  EXPECT_TRUE(CoreFreeForSplit());  // outside any loop
  std::vector<int> free_at(3, -1);
  // Three items on two threads: while both take items no core is free; the last item runs
  // when the other worker has finished.
  ParallelFor(3, 2, [&](int i) { free_at[i] = CoreFreeForSplit() ? 1 : 0; });
  EXPECT_EQ(std::count(free_at.begin(), free_at.end(), -1), 0);
  EXPECT_TRUE(CoreFreeForSplit());  // the state is restored after the loop
  ParallelFor(1, 1, [&](int) { EXPECT_TRUE(CoreFreeForSplit()); });
}

TEST(ParallelChunks, ContiguousChunksCoverTheRange) {
  for (size_t n : {size_t{0}, size_t{1}, size_t{5}, size_t{101}}) {
    std::vector<int> hits(n, 0);
    std::atomic<int> chunks{0};
    ParallelChunks(n, 3, [&](size_t begin, size_t end) {
      ++chunks;
      for (size_t k = begin; k < end; ++k) ++hits[k];
    });
    for (int h : hits) EXPECT_EQ(h, 1) << n;
    EXPECT_EQ(chunks.load(), n < 6 ? 1 : 3) << n;
  }
}

TEST(OnThreads, CallsEveryThreadIndexOnce) {
  std::vector<std::atomic<int>> seen(4);
  OnThreads(4, [&](int t, int threads) {
    EXPECT_EQ(threads, 4);
    ++seen[t];
  });
  for (const auto& s : seen) EXPECT_EQ(s.load(), 1);
}

}  // namespace
}  // namespace mmba
