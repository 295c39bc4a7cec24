#include "core/parallel_for.h"

#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace scanbench {
namespace {

// Persistent workers that run submitted tasks in order. It grows to the
// largest number of helpers any call asked for and lives for the process.
class ThreadPool {
 public:
  static ThreadPool& Shared() {
    static ThreadPool* pool = new ThreadPool();  // never destroyed: workers may still be parked at exit
    return *pool;
  }

  void Submit(int helpers_wanted, const std::function<void()>& task) {
    std::lock_guard<std::mutex> lock(mutex_);
    while (static_cast<int>(workers_.size()) < helpers_wanted) {
      workers_.emplace_back([this] { WorkLoop(); });
      workers_.back().detach();
    }
    tasks_.push_back(task);
    wake_.notify_one();
  }

 private:
  void WorkLoop() {
    for (;;) {
      std::function<void()> task;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [this] { return !tasks_.empty(); });
        task = std::move(tasks_.front());
        tasks_.pop_front();
      }
      task();
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> tasks_;
  std::vector<std::thread> workers_;
};

// What the caller and its helpers share. Helpers hold it by shared_ptr: one
// that starts after the work is over finds `closed` and touches nothing else.
struct ParallelState {
  std::atomic<int> next{0};
  std::atomic<int> done{0};
  std::atomic<bool> stop{false};
  std::mutex mutex;
  std::condition_variable helpers_left;
  bool closed = false;  // no helper may enter once set (under mutex)
  int active = 0;       // helpers inside RunChunks (under mutex)
  int next_worker = 1;  // worker 0 is the caller (under mutex)
  std::exception_ptr error;
};

}  // namespace

int ResolveThreadCount(int requested) {
  if (requested > 0) return requested;
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

bool ParallelFor(int count, int num_threads, int chunk, const std::function<void(int, int, int)>& work,
                 const std::function<bool(int)>& progress) {
  if (count <= 0) return true;
  chunk = std::max(1, chunk);
  const int threads = std::clamp(ResolveThreadCount(num_threads), 1, (count + chunk - 1) / chunk);
  auto state = std::make_shared<ParallelState>();
  bool cancelled = false;  // written by the caller only

  auto run_chunks = [&](int worker, bool is_caller) {
    while (!state->stop.load(std::memory_order_relaxed)) {
      const int first = state->next.fetch_add(chunk);
      if (first >= count) break;
      const int last = std::min(count, first + chunk);
      try {
        work(first, last, worker);
        const int done = state->done.fetch_add(last - first) + (last - first);
        if (is_caller && progress && !progress(done)) {
          cancelled = true;
          state->stop = true;
        }
      } catch (...) {
        std::lock_guard<std::mutex> lock(state->mutex);
        if (!state->error) state->error = std::current_exception();
        state->stop = true;
        break;
      }
    }
  };

  for (int h = 1; h < threads; ++h) {
    ThreadPool::Shared().Submit(threads - 1, [state, &run_chunks] {
      int worker = 0;
      {
        std::lock_guard<std::mutex> lock(state->mutex);
        if (state->closed) return;  // the caller has returned: run_chunks is gone
        worker = state->next_worker++;
        ++state->active;
      }
      run_chunks(worker, false);
      std::lock_guard<std::mutex> lock(state->mutex);
      if (--state->active == 0) state->helpers_left.notify_all();
    });
  }
  run_chunks(0, true);

  std::unique_lock<std::mutex> lock(state->mutex);
  state->closed = true;
  state->helpers_left.wait(lock, [&] { return state->active == 0; });
  if (state->error) std::rethrow_exception(state->error);
  return !cancelled;
}

}  // namespace scanbench
