// One parallel-for over rows or tiles, on one process-wide thread pool: the
// solver, the derived maps, the simulator and occlusion all run through it.
#pragma once

#include <algorithm>
#include <functional>

#include "core/cancellation.h"
#include "core/progress.h"

namespace scanbench {

// Threads to use for `requested`: 0 = every hardware thread; at least 1.
int ResolveThreadCount(int requested);

// Runs work(first, last, worker) over consecutive chunks [first, last) of
// [0, count), each chunk once, on up to `num_threads` threads: the caller and
// num_threads - 1 workers of the shared pool. `worker` in [0, num_threads)
// names the thread that runs the chunk (for per-thread scratch); no two
// chunks run at once with the same `worker`. Chunks are handed out in order
// from a shared counter, so a result written per item never depends on the
// thread count.
//
// Only the calling thread calls `progress`, after each of its chunks, with the
// items done so far; false from it stops every thread at its next chunk and
// ParallelFor returns false. An exception in `work` or `progress` is rethrown
// here once every thread has left `work`. Workers that had not started yet
// when the work ran out are never waited for, so nested calls cannot
// deadlock the pool.
bool ParallelFor(int count, int num_threads, int chunk,
                 const std::function<void(int first, int last, int worker)>& work,
                 const std::function<bool(int items_done)>& progress = {});

// body(row) for every row in [0, rows) on `num_threads` threads (0 = all),
// deterministically. `progress` gets the fraction done mapped onto
// [begin, end]; false from it stops the rows and ParallelRows returns false.
// Returns !progress || progress(end) when every row ran.
template <typename Body>
bool ParallelRows(int rows, int num_threads, const ProgressCallback& progress, double begin, double end,
                  const Body& body) {
  const int threads = ResolveThreadCount(num_threads);
  const int chunk = std::clamp(rows / (8 * threads), 1, 16);
  const bool finished = ParallelFor(
      rows, threads, chunk,
      [&body](int first, int last, int) {
        for (int row = first; row < last; ++row) body(row);
      },
      progress ? std::function<bool(int)>([&](int done) { return progress(begin + (end - begin) * done / rows); })
               : std::function<bool(int)>());
  if (!finished) return false;
  return !progress || progress(end);
}

// ParallelRows for code that has no summary to return (the simulator's
// renders): a stop asked through `progress` throws Cancelled(where).
template <typename Body>
void ParallelRowsOrCancel(const char* where, int rows, int num_threads, const ProgressCallback& progress,
                          double begin, double end, const Body& body) {
  if (!ParallelRows(rows, num_threads, progress, begin, end, body)) throw Cancelled(where);
}

}  // namespace scanbench
