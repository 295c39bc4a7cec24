// Internal to scanbench_sim: runs a function on every image row on a few
// threads, deterministically.
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#include "app/sim/simulated_rig.h"

namespace scanbench::sim_internal {

// Runs body(row) for every row on `num_threads` threads (the caller is one of
// them). Rows are handed out in small chunks from a shared counter, so the
// result never depends on the thread count. Only the calling thread calls
// `progress` (mapped onto [begin, end]); false from it stops the workers and
// throws RenderCancelled. An exception in `body` is rethrown here.
template <typename Body>
void ParallelRows(int rows, int num_threads, const RenderProgressCallback& progress, double begin, double end,
                  const Body& body) {
  std::atomic<int> next_row{0};
  std::atomic<int> rows_done{0};
  std::atomic<bool> stop{false};
  bool cancelled = false;  // written by the calling thread only
  std::exception_ptr error;
  std::mutex error_mutex;
  const int chunk = std::clamp(rows / (8 * std::max(1, num_threads)), 1, 16);

  auto work = [&](bool is_caller) {
    while (!stop.load(std::memory_order_relaxed)) {
      const int first = next_row.fetch_add(chunk);
      if (first >= rows) break;
      const int last = std::min(rows, first + chunk);
      try {
        for (int row = first; row < last; ++row) body(row);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        stop = true;
        break;
      }
      const int done = rows_done.fetch_add(last - first) + (last - first);
      if (is_caller && progress && !progress(begin + (end - begin) * done / rows)) {
        cancelled = true;
        stop = true;
      }
    }
  };

  std::vector<std::thread> helpers;
  for (int t = 1; t < num_threads; ++t) helpers.emplace_back(work, false);
  work(true);
  for (std::thread& helper : helpers) helper.join();
  if (error) std::rethrow_exception(error);
  if (cancelled) throw RenderCancelled();
  if (progress && !progress(end)) throw RenderCancelled();
}

}  // namespace scanbench::sim_internal
