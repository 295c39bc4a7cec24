// ParallelFor / ParallelRows: every item once, results independent of the
// thread count, the caller alone reports progress, a stop and an exception end
// every thread, and nested calls on the shared pool finish.
#include "core/parallel_for.h"

#include <atomic>
#include <cmath>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace scanbench {
namespace {

std::vector<double> RowSums(int rows, int threads) {
  std::vector<double> sums(rows, 0.0);
  const bool finished = ParallelRows(rows, threads, {}, 0, 1, [&](int row) {
    double sum = 0;
    for (int x = 0; x < 1000; ++x) sum += std::sin(0.001 * x * (row + 1));
    sums[row] = sum;
  });
  EXPECT_TRUE(finished);
  return sums;
}

TEST(ParallelForTest, EveryItemRunsExactlyOnce) {
  for (int threads : {1, 2, 3, 8}) {
    for (int chunk : {1, 7, 100}) {
      std::vector<std::atomic<int>> runs(1001);
      ASSERT_TRUE(ParallelFor(1001, threads, chunk, [&](int first, int last, int) {
        for (int i = first; i < last; ++i) ++runs[i];
      }));
      for (int i = 0; i < 1001; ++i) ASSERT_EQ(runs[i].load(), 1) << "item " << i << " threads " << threads;
    }
  }
}

TEST(ParallelForTest, ResultDoesNotDependOnTheThreadCount) {
  const std::vector<double> one = RowSums(257, 1);
  EXPECT_EQ(RowSums(257, 2), one);
  EXPECT_EQ(RowSums(257, 5), one);
}

TEST(ParallelForTest, WorkerSlotsAreDistinctAndInRange) {
  constexpr int kThreads = 4;
  std::vector<std::atomic<int>> inside(kThreads);
  std::atomic<bool> overlap{false}, out_of_range{false};
  ASSERT_TRUE(ParallelFor(400, kThreads, 1, [&](int, int, int worker) {
    if (worker < 0 || worker >= kThreads) {
      out_of_range = true;
      return;
    }
    if (inside[worker]++ != 0) overlap = true;
    std::this_thread::sleep_for(std::chrono::microseconds(50));
    --inside[worker];
  }));
  EXPECT_FALSE(out_of_range);
  EXPECT_FALSE(overlap);
}

TEST(ParallelForTest, ProgressRunsOnTheCallerOnlyAndEndsAtOne) {
  const std::thread::id caller = std::this_thread::get_id();
  std::vector<double> seen;
  bool other_thread = false;
  const bool finished = ParallelRows(
      200, 3,
      [&](double fraction) {
        if (std::this_thread::get_id() != caller) other_thread = true;
        seen.push_back(fraction);
        return true;
      },
      0.25, 0.75, [](int) { std::this_thread::sleep_for(std::chrono::microseconds(20)); });
  EXPECT_TRUE(finished);
  EXPECT_FALSE(other_thread);
  ASSERT_FALSE(seen.empty());
  EXPECT_DOUBLE_EQ(seen.back(), 0.75);
  for (size_t i = 1; i < seen.size(); ++i) EXPECT_LE(seen[i - 1], seen[i]);
  EXPECT_GE(seen.front(), 0.25);
}

TEST(ParallelForTest, FalseFromProgressStopsEarly) {
  std::atomic<int> rows_run{0};
  int calls = 0;
  const bool finished = ParallelRows(
      10000, 2, [&](double) { return ++calls < 3; }, 0, 1,
      [&](int) {
        ++rows_run;
        std::this_thread::sleep_for(std::chrono::microseconds(10));
      });
  EXPECT_FALSE(finished);
  EXPECT_LT(rows_run.load(), 10000);
}

TEST(ParallelForTest, ExceptionIsRethrownOnTheCaller) {
  EXPECT_THROW(ParallelFor(1000, 3, 1,
                           [](int first, int, int) {
                             if (first == 517) throw std::runtime_error("row 517");
                           }),
               std::runtime_error);
  // The pool is still usable afterwards.
  std::atomic<int> sum{0};
  EXPECT_TRUE(ParallelFor(100, 3, 1, [&](int first, int last, int) { sum += last - first; }));
  EXPECT_EQ(sum.load(), 100);
}

TEST(ParallelForTest, NestedCallsFinish) {
  // Every outer item runs an inner parallel loop on the same pool: the inner
  // callers never wait for helpers that have not started.
  std::atomic<long> total{0};
  ASSERT_TRUE(ParallelFor(16, 4, 1, [&](int, int, int) {
    EXPECT_TRUE(ParallelFor(64, 4, 1, [&](int first, int last, int) { total += last - first; }));
  }));
  EXPECT_EQ(total.load(), 16 * 64);
}

TEST(ParallelForTest, CallsFromManyThreadsAtOnce) {
  std::vector<std::thread> callers;
  std::atomic<long> total{0};
  for (int c = 0; c < 4; ++c) {
    callers.emplace_back([&] {
      for (int repeat = 0; repeat < 20; ++repeat) {
        ParallelFor(50, 3, 2, [&](int first, int last, int) { total += last - first; });
      }
    });
  }
  for (std::thread& caller : callers) caller.join();
  EXPECT_EQ(total.load(), 4L * 20 * 50);
}

TEST(ParallelForTest, OrCancelThrowsCancelledNamingTheStep) {
  try {
    ParallelRowsOrCancel("render", 100, 2, [](double) { return false; }, 0, 1, [](int) {});
    FAIL() << "no exception";
  } catch (const Cancelled& cancelled) {
    EXPECT_STREQ(cancelled.what(), "cancelled during render");
  }
}

TEST(ParallelForTest, EmptyRangeAndThreadCount) {
  EXPECT_TRUE(ParallelFor(0, 4, 1, [](int, int, int) { FAIL(); }));
  EXPECT_EQ(ResolveThreadCount(3), 3);
  EXPECT_GE(ResolveThreadCount(0), 1);
}

}  // namespace
}  // namespace scanbench
