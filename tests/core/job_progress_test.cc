// JobProgress (issue #36 item 8): one bar for a job of several stages.
#include "core/job_progress.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace scanbench {
namespace {

// A solve-while-capturing job as the GUI saw it: "capture: 36 %" then
// "solve: 7 %" moved a per-stage bar back; the job's bar moves on, names the
// stage, and ends as "finished".
TEST(JobProgressTest, PlannedStagesMakeOneBarThatNeverMovesBack) {
  JobProgress job({{"capture", 11}, {"decode RAW", 4}, {"solve", 4}, {"write maps", 1}});
  EXPECT_EQ(job.Text(), "starting");
  job.Update({"capture", "", 0.36});
  EXPECT_NEAR(job.fraction(), 0.36 * 11 / 20, 1e-12);
  EXPECT_EQ(job.Text(), "capture (stage 1 of 4): 36 %");
  const double after_capture = job.fraction();
  job.Update({"solve", "band 2/9", 0.07});
  EXPECT_NEAR(job.fraction(), (15 + 0.07 * 4) / 20, 1e-12);
  EXPECT_GT(job.fraction(), after_capture);
  EXPECT_EQ(job.stage_number(), 3);
  EXPECT_EQ(job.Text(), "solve (stage 3 of 4): 7 % \u2014 band 2/9");
  // A late report of an earlier stage (another thread) names it but moves nothing back.
  const double before = job.fraction();
  job.Update({"decode RAW", "", 0.5});
  EXPECT_EQ(job.fraction(), before);
  EXPECT_EQ(job.stage(), "decode RAW");
  job.Update({"write maps", "", 1});
  EXPECT_DOUBLE_EQ(job.fraction(), 1);
  EXPECT_FALSE(job.finished());
  job.Finish(true);
  EXPECT_TRUE(job.finished());
  EXPECT_EQ(job.Text(), "finished");
  job.Update({"capture", "", 0});  // after the end: ignored
  EXPECT_DOUBLE_EQ(job.fraction(), 1);
}

// Without a plan (or a stage the plan does not name) each stage takes half
// of what is left: the bar moves forward, never reaches the end before the
// job does, and a stopped job says so.
TEST(JobProgressTest, UnplannedStagesTakeHalfOfWhatIsLeft) {
  JobProgress job;
  job.Update({"read", "", 1});
  EXPECT_DOUBLE_EQ(job.fraction(), 0.5);
  job.Update({"fit", "", 0});
  EXPECT_DOUBLE_EQ(job.fraction(), 0.5);
  job.Update({"fit", "", 1});
  EXPECT_DOUBLE_EQ(job.fraction(), 0.75);
  EXPECT_EQ(job.stage_number(), 0);
  EXPECT_EQ(job.Text(), "fit: 100 %");
  job.Finish(false);
  EXPECT_EQ(job.Text(), "stopped");
  EXPECT_DOUBLE_EQ(job.fraction(), 0.75);

  JobProgress planned({{"capture", 1}});
  planned.Update({"capture", "", 0.5});
  planned.Update({"surprise", "", 1});
  EXPECT_DOUBLE_EQ(planned.fraction(), 0.75);
}

}  // namespace
}  // namespace scanbench
