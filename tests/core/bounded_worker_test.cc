// BoundedWorker: every item once and in order, never more than `capacity`
// waiting, a failure rethrown to the pusher and the items behind it dropped,
// a destroyed worker drops what waits but finishes what it works on.
#include "core/bounded_worker.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace scanbench {
namespace {

// A gate the work waits at until the test opens it.
class Gate {
 public:
  void Open() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      open_ = true;
    }
    changed_.notify_all();
  }
  void Wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [&] { return open_; });
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  bool open_ = false;
};

TEST(BoundedWorkerTest, WorksEveryItemOnceInOrder) {
  std::vector<int> done;  // the worker's only
  BoundedWorker<int> worker([&](int& item) { done.push_back(item); }, 3);
  for (int i = 0; i < 1000; ++i) worker.Push(i);
  worker.Finish();
  ASSERT_EQ(done.size(), 1000u);
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(done[i], i);
}

TEST(BoundedWorkerTest, NeverMoreThanCapacityWait) {
  for (const int capacity : {1, 2, 5}) {
    std::atomic<int> most_waiting{0};
    BoundedWorker<int>* self = nullptr;
    BoundedWorker<int> worker(
        [&](int&) {
          most_waiting = std::max(most_waiting.load(), self->waiting());
          std::this_thread::yield();
        },
        capacity);
    self = &worker;
    for (int i = 0; i < 200; ++i) worker.Push(i);
    worker.Finish();
    EXPECT_LE(most_waiting.load(), capacity);
    EXPECT_GE(most_waiting.load(), 0);
  }
}

TEST(BoundedWorkerTest, PushWaitsForRoom) {
  Gate gate;
  std::atomic<int> started{0};
  BoundedWorker<int> worker(
      [&](int&) {
        ++started;
        gate.Wait();
      },
      1);
  worker.Push(0);  // taken by the worker, which waits at the gate
  while (started.load() == 0) std::this_thread::yield();
  worker.Push(1);  // waits in the queue: now it is full
  std::atomic<bool> third_pushed{false};
  std::thread pusher([&] {
    worker.Push(2);
    third_pushed = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(third_pushed.load());
  EXPECT_EQ(worker.waiting(), 1);
  gate.Open();
  pusher.join();
  EXPECT_TRUE(third_pushed.load());
  worker.Finish();
  EXPECT_EQ(started.load(), 3);
}

TEST(BoundedWorkerTest, AFailureIsRethrownAndDropsTheRest) {
  std::vector<int> done;
  BoundedWorker<int> worker(
      [&](int& item) {
        if (item == 3) throw std::runtime_error("item 3 is bad");
        done.push_back(item);
      },
      100);
  bool thrown = false;
  try {
    for (int i = 0; i < 10; ++i) worker.Push(i);
    worker.Finish();
  } catch (const std::runtime_error& error) {
    thrown = true;
    EXPECT_STREQ(error.what(), "item 3 is bad");
  }
  EXPECT_TRUE(thrown);
  EXPECT_EQ(done, (std::vector<int>{0, 1, 2}));  // nothing after the failure
}

TEST(BoundedWorkerTest, DestructionDropsWhatWaitsAndFinishesTheCurrentItem) {
  Gate gate;
  std::atomic<int> started{0}, finished{0};
  std::thread opener;
  {
    BoundedWorker<int> worker(
        [&](int&) {
          ++started;
          gate.Wait();
          ++finished;
        },
        4);
    for (int i = 0; i < 4; ++i) worker.Push(i);
    while (started.load() == 0) std::this_thread::yield();
    opener = std::thread([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      gate.Open();
    });
  }  // the destructor waits for the item the gate holds
  opener.join();
  EXPECT_EQ(started.load(), 1);
  EXPECT_EQ(finished.load(), 1);
}

TEST(BoundedWorkerTest, FinishingAndThreadStartAreSeenByTheWork) {
  std::atomic<bool> thread_started{false};
  std::vector<bool> seen_finishing;
  Gate gate;
  BoundedWorker<int>* self = nullptr;
  BoundedWorker<int> worker(
      [&](int& item) {
        if (item == 0) gate.Wait();
        seen_finishing.push_back(self->finishing());
      },
      4, [&] { thread_started = true; });
  self = &worker;
  worker.Push(0);
  worker.Push(1);
  std::thread finisher([&] { worker.Finish(); });
  while (!worker.finishing()) std::this_thread::yield();
  gate.Open();
  finisher.join();
  EXPECT_TRUE(thread_started.load());
  EXPECT_EQ(seen_finishing, (std::vector<bool>{true, true}));
}

TEST(BoundedWorkerTest, BadArgumentsAreRefused) {
  EXPECT_THROW(BoundedWorker<int>([](int&) {}, 0), std::invalid_argument);
  EXPECT_THROW(BoundedWorker<int>({}, 1), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
