// Runs a function on every image row on a few threads, deterministically:
// shared by the simulator and the derived maps (no dependency beyond std).
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace scanbench {

// Runs body(row) for every row on `num_threads` threads (the caller is one of
// them). Rows are handed out in small chunks from a shared counter, so the
// result never depends on the thread count. Only the calling thread calls
// `progress` (the fraction done mapped onto [begin, end]); false from it stops
// the workers and ParallelRows returns false. An exception in `body` or
// `progress` is rethrown here once every thread has stopped.
template <typename Body>
bool ParallelRows(int rows, int num_threads, const std::function<bool(double)>& progress, double begin, double end,
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
      // The progress call is inside the try too: an exception escaping here
      // would leave the helper threads joinable, which terminates the program.
      try {
        for (int row = first; row < last; ++row) body(row);
        const int done = rows_done.fetch_add(last - first) + (last - first);
        if (is_caller && progress && !progress(begin + (end - begin) * done / rows)) {
          cancelled = true;
          stop = true;
        }
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        stop = true;
        break;
      }
    }
  };

  std::vector<std::thread> helpers;
  for (int t = 1; t < num_threads; ++t) helpers.emplace_back(work, false);
  work(true);
  for (std::thread& helper : helpers) helper.join();
  if (error) std::rethrow_exception(error);
  if (cancelled) return false;
  return !progress || progress(end);
}

}  // namespace scanbench
