// StageTimes: each stage's own time. The figures are asserted through Add
// (seconds given, not measured), with margins no machine's load reaches, so
// that nothing depends on speed.
#include "app/controllers/base_controller.h"

#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace scanbench {
namespace {

using ::testing::ElementsAre;

double SecondsOf(const std::vector<StageTiming>& list, const std::string& stage) {
  for (const StageTiming& timing : list) {
    if (timing.stage == stage) return timing.seconds;
  }
  ADD_FAILURE() << "no stage " << stage;
  return 0;
}

std::vector<std::string> StagesOf(const std::vector<StageTiming>& list) {
  std::vector<std::string> stages;
  for (const StageTiming& timing : list) stages.push_back(timing.stage);
  return stages;
}

// What a step's sink does on the step's thread counts for the sink's stage,
// not for the step's too; the stages are listed in the constructor's order,
// only those timed.
TEST(StageTimesTest, ATimeInsideAStepOnItsThreadIsTheInnerStagesOnly) {
  StageTimes times({"load", "solve", "write", "evaluate", "unused"});
  times.Time("solve", [&] {
    times.Time("write", [&] { times.Add("evaluate", 1000); });
    times.Add("write", 2000);
  });
  times.Time("load", [] {});
  const std::vector<StageTiming> list = times.List();
  EXPECT_THAT(StagesOf(list), ElementsAre("load", "solve", "write", "evaluate"));
  EXPECT_EQ(SecondsOf(list, "evaluate"), 1000);
  // write: its own step (a few microseconds) less the evaluation inside it, and 2000 s added.
  EXPECT_GT(SecondsOf(list, "write"), 2000 - 1000 - 100);
  EXPECT_LT(SecondsOf(list, "write"), 2000 - 1000 + 100);
  // solve: its step less the write step (its whole time) and the 2000 s added inside it.
  EXPECT_LT(SecondsOf(list, "solve"), -2000 + 100);
  EXPECT_GE(SecondsOf(list, "load"), 0);
}

// A sink on a thread of its own (a band writer beside the solve) adds to its
// stage and takes nothing from the step running on the other thread.
TEST(StageTimesTest, ATimeOnAnotherThreadTakesNothingFromTheStep) {
  StageTimes times({"solve", "write", "evaluate"});
  times.Time("solve", [&] {
    std::thread writer([&] {
      times.Time("write", [&] { times.Add("evaluate", 1000); });
      times.Add("evaluate", 2000);
    });
    writer.join();
  });
  const std::vector<StageTiming> list = times.List();
  EXPECT_GE(SecondsOf(list, "solve"), 0);
  EXPECT_LT(SecondsOf(list, "write"), -1000 + 100) << "the evaluation inside it is taken from it";
  EXPECT_EQ(SecondsOf(list, "evaluate"), 3000);
}

TEST(StageTimesTest, AStageTimedTwiceAddsUpAndAFailedStepAddsNothing) {
  StageTimes times({"write", "evaluate"});
  times.Add("write", 1);
  times.Add("write", 2);
  EXPECT_THROW(times.Time("evaluate", [&]() -> int { throw std::runtime_error("failed"); }), std::runtime_error);
  EXPECT_EQ(times.Time("write", [] { return 7; }), 7);
  const std::vector<StageTiming> list = times.List();
  EXPECT_THAT(StagesOf(list), ElementsAre("write"));
  EXPECT_GE(SecondsOf(list, "write"), 3);
  EXPECT_THROW(times.Add("decode", 1), std::logic_error);
}

}  // namespace
}  // namespace scanbench
