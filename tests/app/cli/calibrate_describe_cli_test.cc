// `scanbench calibrate describe` through the real binary: captures without
// target.json become target sessions, a second run keeps them, and errors name
// the session or option and the rule with exit code 1.
#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/session/calibration_target.h"
#include "tests/util/command_runner.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// The describe command only needs a session folder; its session.json is not read.
fs::path MakeCapture(const fs::path& dir) {
  fs::create_directories(dir);
  std::ofstream(dir / "session.json") << "{}\n";
  return dir;
}

TEST(CalibrateDescribeCliTest, HelpListsEveryOption) {
  const CommandResult help = RunScanbench("calibrate describe --help");
  EXPECT_EQ(help.exit_code, 0);
  for (const char* option : {"sessions", "--as", "--spacer-mm", "checkerboard", "gray_chart", "white_sheet", "color_chart"}) {
    EXPECT_THAT(help.output, HasSubstr(option));
  }
  EXPECT_THAT(RunScanbench("calibrate --help").output, HasSubstr("describe"));
}

TEST(CalibrateDescribeCliTest, WritesTheTableSheetThenTheSpacerSheetAndKeepsThemOnARerun) {
  testing::TemporaryFolder folder;
  const fs::path table = MakeCapture(folder / "table"), spacer = MakeCapture(folder / "spacer");
  const CommandResult first = RunScanbench("calibrate describe " + Quoted(table) + " " + Quoted(spacer) +
                                           " --as white_sheet --spacer-mm 30");
  ASSERT_EQ(first.exit_code, 0) << first.output;
  EXPECT_THAT(first.output, HasSubstr("target.json written: the sheet on the table"));
  EXPECT_THAT(first.output, HasSubstr("target.json written: the sheet on the 30 mm spacer"));
  EXPECT_EQ(LoadCalibrationTarget(table).white_sheet.height_mm, 0);
  EXPECT_EQ(LoadCalibrationTarget(spacer).white_sheet.height_mm, 30);

  const CommandResult again = RunScanbench("calibrate describe " + Quoted(spacer) + " --as white_sheet");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_THAT(again.output, HasSubstr("kept its target.json"));
  EXPECT_EQ(LoadCalibrationTarget(spacer).white_sheet.height_mm, 30);
}

TEST(CalibrateDescribeCliTest, DescribesBoardPosesAndTheGrayChart) {
  testing::TemporaryFolder folder;
  const fs::path flat = MakeCapture(folder / "b0"), tilted = MakeCapture(folder / "b1");
  const CommandResult boards =
      RunScanbench("calibrate describe " + Quoted(flat) + " " + Quoted(tilted) + " --as checkerboard");
  ASSERT_EQ(boards.exit_code, 0) << boards.output;
  EXPECT_TRUE(LoadCalibrationTarget(flat).on_table);
  EXPECT_FALSE(LoadCalibrationTarget(tilted).on_table);
  const fs::path chart = MakeCapture(folder / "chart");
  ASSERT_EQ(RunScanbench("calibrate describe " + Quoted(chart) + " --as gray_chart").exit_code, 0);
  EXPECT_EQ(LoadCalibrationTarget(chart).kind, CalibrationTargetDescription::Kind::kGrayChart);
}

TEST(CalibrateDescribeCliTest, ErrorsNameTheSessionOrOptionAndTheRule) {
  testing::TemporaryFolder folder;
  fs::create_directories(folder / "empty");
  const CommandResult no_session = RunScanbench("calibrate describe " + Quoted(folder / "empty") + " --as gray_chart");
  EXPECT_EQ(no_session.exit_code, 1);
  EXPECT_THAT(no_session.output, HasSubstr("empty holds no session.json: capture it first"));

  const fs::path capture = MakeCapture(folder / "c");
  const CommandResult spacer =
      RunScanbench("calibrate describe " + Quoted(capture) + " --as white_sheet --spacer-mm 0");
  EXPECT_EQ(spacer.exit_code, 1);
  EXPECT_THAT(spacer.output, HasSubstr("--spacer-mm 0: must lie in (0, 200] mm"));  // the option as typed (issue #36)
  EXPECT_FALSE(fs::exists(capture / kCalibrationTargetFileName));

  const CommandResult kind = RunScanbench("calibrate describe " + Quoted(capture) + " --as tablecloth");
  EXPECT_NE(kind.exit_code, 0);
  EXPECT_THAT(kind.output, HasSubstr("tablecloth"));
}

}  // namespace
}  // namespace scanbench
