// One thread that works through a bounded queue of items in the order they
// are pushed: the solve's band writer (solve_controller.cc) and the live
// solve's frame decoder (live_solve.cc) hand work to it so that their own
// thread goes on (solving the next band, taking the next frame).
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>

namespace scanbench {

template <typename T>
class BoundedWorker {
 public:
  // `work(item)` runs on the worker's thread for every pushed item, in order;
  // at most `capacity` (>= 1) items wait, and Push blocks beyond that.
  // `on_thread_start`, optional, runs first on that thread (e.g. to lower its
  // priority). An exception from `work` stops the worker: the items still
  // waiting are dropped and the next Push or Finish rethrows it.
  BoundedWorker(std::function<void(T& item)> work, int capacity, std::function<void()> on_thread_start = {})
      : work_(std::move(work)), capacity_(capacity), on_thread_start_(std::move(on_thread_start)) {
    if (!work_ || capacity_ < 1) {
      throw std::invalid_argument("BoundedWorker: capacity " + std::to_string(capacity_) +
                                  " must be >= 1 and the work must not be empty");
    }
    thread_ = std::thread([this] { Loop(); });  // everything above exists
  }
  BoundedWorker(const BoundedWorker&) = delete;
  BoundedWorker& operator=(const BoundedWorker&) = delete;

  // Drops what still waits (a failed or cancelled job); an item being worked
  // on is finished first.
  ~BoundedWorker() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closing_ = true;
      queue_.clear();
    }
    changed_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

  // Queues `item`, waiting while `capacity` items wait. Rethrows the work's
  // failure on an earlier item. Not after Finish.
  void Push(T item) {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [&] { return failure_ || closing_ || static_cast<int>(queue_.size()) < capacity_; });
    if (failure_) std::rethrow_exception(failure_);
    if (closing_) throw std::logic_error("BoundedWorker::Push after Finish");
    queue_.push_back(std::move(item));
    changed_.notify_all();
  }

  // Waits until every pushed item is done and ends the thread; rethrows the
  // work's failure. From the moment it is called finishing() is true.
  void Finish() {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      finishing_ = true;
      changed_.wait(lock, [&] { return failure_ || (queue_.empty() && !busy_); });
      closing_ = true;
    }
    changed_.notify_all();
    if (thread_.joinable()) thread_.join();
    if (failure_) std::rethrow_exception(failure_);
  }

  // For the work's own rules (e.g. do more only while nothing waits):
  // items waiting behind the one being worked on, and whether Finish was called.
  int waiting() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return static_cast<int>(queue_.size());
  }
  bool finishing() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return finishing_;
  }

 private:
  void Loop() {
    if (on_thread_start_) on_thread_start_();
    for (;;) {
      T item;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        changed_.wait(lock, [&] { return closing_ || !queue_.empty(); });
        if (queue_.empty()) return;  // closing
        item = std::move(queue_.front());
        queue_.pop_front();
        busy_ = true;
      }
      changed_.notify_all();  // room in the queue
      std::exception_ptr failure;
      try {
        work_(item);
      } catch (...) {
        failure = std::current_exception();
      }
      {
        std::lock_guard<std::mutex> lock(mutex_);
        busy_ = false;
        if (failure) {
          failure_ = failure;
          queue_.clear();
        }
      }
      changed_.notify_all();
      if (failure) return;
    }
  }

  const std::function<void(T& item)> work_;
  const int capacity_;
  const std::function<void()> on_thread_start_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<T> queue_;         // under mutex_
  bool busy_ = false;           // under mutex_: an item is being worked on
  bool finishing_ = false;      // under mutex_: Finish was called
  bool closing_ = false;        // under mutex_: the thread ends when the queue is empty
  std::exception_ptr failure_;  // under mutex_
  std::thread thread_;          // started last, in the constructor
};

}  // namespace scanbench
