#pragma once

namespace mmba {

/// Large point clouds and LiDAR images are allocated and freed in buffers of hundreds of MB.
/// Each fresh 4 KiB page costs a page fault, and on virtual machines a fault is slow: before
/// this, page faults took a third to a half of `register-cloud`'s time on a 27 M + 24 M point
/// pair (bench/RESULTS.md). glibc (≥ 2.35) can back its allocations with 2 MiB transparent
/// huge pages, but only through the GLIBC_TUNABLES environment variable read at start-up.
///
/// So this re-executes the program once (execv of /proc/self/exe with the same arguments)
/// with `glibc.malloc.hugetlb=1` added to GLIBC_TUNABLES, when
///  - the tunable is not set yet (so it happens at most once),
///  - transparent huge pages are not disabled ("[never]" in
///    /sys/kernel/mm/transparent_hugepage/enabled), and
///  - MMBA_HUGE_PAGES is not "0" (the user's switch to keep glibc's default).
/// It does nothing elsewhere (not Linux, or the exec fails: the program goes on as it is).
/// Results do not change: only where the memory comes from.
void ReexecWithHugePageMalloc(char** argv);

}  // namespace mmba
