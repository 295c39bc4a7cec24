#include "core/summary.h"

#include <stdexcept>

#include <gtest/gtest.h>

#include "core/cancellation.h"

namespace scanbench {
namespace {

struct ExampleSummary : AlgorithmSummary {
  int figure = 0;
};

TEST(SummaryTest, StartsAsAFailureUntilTheAlgorithmSaysOtherwise) {
  ExampleSummary summary;
  EXPECT_EQ(summary.termination, Termination::kFailure);
  EXPECT_FALSE(summary.IsUsable());
  summary.termination = Termination::kSuccess;
  EXPECT_TRUE(summary.IsUsable());
  summary.SetCancelled();
  EXPECT_TRUE(summary.IsCancelled());
  EXPECT_FALSE(summary.IsUsable());
  EXPECT_EQ(summary.message, "cancelled");
}

TEST(SummaryTest, TerminationNames) {
  EXPECT_STREQ(TerminationName(Termination::kSuccess), "success");
  EXPECT_STREQ(TerminationName(Termination::kFailure), "failure");
  EXPECT_STREQ(TerminationName(Termination::kCancelled), "cancelled");
}

TEST(SummaryTest, RequireSuccessThrowsTheOneCancellationType) {
  ExampleSummary summary;
  summary.termination = Termination::kSuccess;
  EXPECT_NO_THROW(RequireSuccess(summary, "height"));
  summary.SetCancelled();
  try {
    RequireSuccess(summary, "height");
    FAIL() << "no exception";
  } catch (const Cancelled& cancelled) {
    EXPECT_STREQ(cancelled.what(), "cancelled during height");
  }
  summary.SetFailure("no valid pixel");
  try {
    RequireSuccess(summary, "height");
    FAIL() << "no exception";
  } catch (const Cancelled&) {
    FAIL() << "a failure is not a cancellation";
  } catch (const std::runtime_error& error) {
    EXPECT_STREQ(error.what(), "height: no valid pixel");
  }
}

}  // namespace
}  // namespace scanbench
