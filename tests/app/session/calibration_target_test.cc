// Target sessions on disk: target.json round trips, finding the target
// sessions of each kind in a folder, and describing real-bench captures (plain
// sessions) as the standard targets.
#include "app/session/calibration_target.h"

#include <filesystem>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/session/session.h"
#include "tests/app/session/session_test_util.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using testing_util::MakeTestSession;
using testing_util::ReadText;
using testing_util::TemporaryFolder;
using testing_util::WriteText;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::ThrowsMessage;
using Kind = CalibrationTargetDescription::Kind;

// A capture as the Capture page leaves it: a session without target.json.
fs::path MakeCapture(const fs::path& dir) {
  CreateSessionFolder(dir);
  WriteSessionManifest(dir, MakeTestSession());
  return dir;
}

CalibrationTargetDescription Sheet(double height_mm) {
  CalibrationTargetDescription target;
  target.kind = Kind::kWhiteSheet;
  target.white_sheet.height_mm = height_mm;
  return target;
}

TEST(CalibrationTargetTest, KindNamesRoundTrip) {
  for (const Kind kind : {Kind::kCheckerboard, Kind::kGrayChart, Kind::kWhiteSheet, Kind::kColorChart}) {
    EXPECT_EQ(CalibrationTargetKindFromName(CalibrationTargetKindName(kind)), kind);
  }
  EXPECT_FALSE(CalibrationTargetKindFromName("white sheet").has_value());
}

TEST(CalibrationTargetTest, EachKindRoundTripsThroughTargetJson) {
  CalibrationTargetDescription board;
  board.kind = Kind::kCheckerboard;
  board.on_table = true;
  board.board_height_mm = 2.5;
  CalibrationTargetDescription chart;
  chart.kind = Kind::kGrayChart;
  chart.gray_chart = GrayChartTarget::MunsellNeutralScale();
  CalibrationTargetDescription colour;
  colour.kind = Kind::kColorChart;
  colour.color_chart.patch_mm = 16;
  colour.color_chart.pitch_mm = 20;
  colour.color_chart.height_mm = 3;
  for (const CalibrationTargetDescription& target : {board, chart, Sheet(40), colour}) {
    const std::string text = CalibrationTargetToJson(target);
    const CalibrationTargetDescription back = CalibrationTargetFromJson(text, "target.json");
    EXPECT_EQ(back.kind, target.kind);
    EXPECT_EQ(CalibrationTargetToJson(back), text) << "written again byte for byte";
  }
  const CalibrationTargetDescription back = CalibrationTargetFromJson(CalibrationTargetToJson(colour), "t.json");
  EXPECT_EQ(back.color_chart.chart, "colorchecker_classic");
  EXPECT_EQ(back.color_chart.pitch_mm, 20);
  EXPECT_EQ(back.color_chart.height_mm, 3);
  EXPECT_THAT(CalibrationTargetToJson(colour), HasSubstr("\"kind\": \"color_chart\""));
  // Only the target's own section is written.
  EXPECT_THAT(CalibrationTargetToJson(Sheet(40)), Not(HasSubstr("checkerboard\":")));
}

TEST(CalibrationTargetTest, UnknownKeysAndBadSectionsAreRefusedByName) {
  const std::string good = CalibrationTargetToJson(Sheet(40));
  std::string misspelt = good;
  misspelt.replace(misspelt.find("\"height_mm\""), 11, "\"hieght_mm\"");
  EXPECT_THAT([&] { CalibrationTargetFromJson(misspelt, "t.json"); },
              ThrowsMessage<SessionError>(HasSubstr("t.json: white_sheet.hieght_mm: unknown field (misspelt?)")));
  std::string missing = good;
  missing.replace(missing.find("\"white_sheet\": {"), 16, "\"gray_chart\": {");
  EXPECT_THAT([&] { CalibrationTargetFromJson(missing, "t.json"); },
              ThrowsMessage<SessionError>(HasSubstr("t.json: white_sheet: missing required field")));
}

TEST(CalibrationTargetTest, ColorChartFieldsAreCheckedByName) {
  CalibrationTargetDescription colour;
  colour.kind = Kind::kColorChart;
  const std::string good = CalibrationTargetToJson(colour);
  std::string other_chart = good;
  other_chart.replace(other_chart.find("colorchecker_classic"), 20, "colorchecker_passpor");
  EXPECT_THAT([&] { CalibrationTargetFromJson(other_chart, "t.json"); },
              ThrowsMessage<SessionError>(HasSubstr("must be \"colorchecker_classic\"")));
  std::string bad_pitch = good;
  bad_pitch.replace(bad_pitch.find("\"pitch_mm\": 20.0"), 16, "\"pitch_mm\": 10.0");
  EXPECT_THAT([&] { CalibrationTargetFromJson(bad_pitch, "t.json"); },
              ThrowsMessage<SessionError>(HasSubstr("pitch_mm = 10 must lie in [patch_mm = 16")));
  EXPECT_FALSE(IsTableView(colour));
}

TEST(CalibrationTargetTest, DescribesACaptureAsTheRealSizeColorChecker) {
  TemporaryFolder folder;
  const fs::path capture = MakeCapture(folder / "chart");
  DescribeTargetsOptions options;
  options.kind = Kind::kColorChart;
  const auto described = DescribeTargetSessions(options, {capture});
  ASSERT_EQ(described.size(), 1u);
  EXPECT_TRUE(described[0].written);
  EXPECT_EQ(described[0].what, "the ColorChecker Classic");
  const CalibrationTargetDescription written = LoadCalibrationTarget(capture);
  EXPECT_EQ(written.kind, Kind::kColorChart);
  EXPECT_EQ(written.color_chart.pitch_mm, 40);
  EXPECT_EQ(FindTargetSessions(folder.path()).at(Kind::kColorChart), std::vector<fs::path>{capture});
}

TEST(CalibrationTargetTest, FindsTheTargetSessionsOfEachKindSortedAndSkipsUnreadableOnes) {
  TemporaryFolder folder;
  WriteCalibrationTarget(MakeCapture(folder / "b_sheet"), Sheet(40));
  WriteCalibrationTarget(MakeCapture(folder / "a_sheet"), Sheet(0));
  MakeCapture(folder / "scan");  // no target.json: no target session
  fs::create_directories(folder / "broken");
  WriteText(folder / "broken" / kCalibrationTargetFileName, "{");
  const auto found = FindTargetSessions(folder.path());
  ASSERT_EQ(found.size(), 1u);
  ASSERT_TRUE(found.count(Kind::kWhiteSheet));
  EXPECT_EQ(found.at(Kind::kWhiteSheet), (std::vector<fs::path>{folder / "a_sheet", folder / "b_sheet"}));
  // A target session itself.
  EXPECT_EQ(FindTargetSessions(folder / "a_sheet").at(Kind::kWhiteSheet), std::vector<fs::path>{folder / "a_sheet"});
  EXPECT_TRUE(FindTargetSessions(folder / "does-not-exist").empty());
}

TEST(CalibrationTargetTest, DescribesTheFirstSheetOnTheTableAndTheOthersOnTheSpacer) {
  TemporaryFolder folder;
  const fs::path table = MakeCapture(folder / "one"), spacer = MakeCapture(folder / "two");
  DescribeTargetsOptions options;
  options.kind = Kind::kWhiteSheet;
  options.spacer_mm = 25;
  const auto described = DescribeTargetSessions(options, {table, spacer});
  ASSERT_EQ(described.size(), 2u);
  EXPECT_TRUE(described[0].written);
  EXPECT_EQ(described[0].what, "the sheet on the table");
  EXPECT_EQ(described[1].what, "the sheet on the 25 mm spacer");
  EXPECT_EQ(LoadCalibrationTarget(table).white_sheet.height_mm, 0);
  EXPECT_EQ(LoadCalibrationTarget(spacer).white_sheet.height_mm, 25);
  EXPECT_TRUE(IsTableView(LoadCalibrationTarget(table)));
  EXPECT_FALSE(IsTableView(LoadCalibrationTarget(spacer)));

  // Described once: a second call keeps both files as they are.
  const std::string before = ReadText(spacer / kCalibrationTargetFileName);
  options.spacer_mm = 60;
  const auto again = DescribeTargetSessions(options, {table, spacer});
  EXPECT_FALSE(again[0].written);
  EXPECT_FALSE(again[1].written);
  EXPECT_EQ(ReadText(spacer / kCalibrationTargetFileName), before);
}

TEST(CalibrationTargetTest, ABoardAlreadyOnTheTableMakesTheNewOnesTilted) {
  TemporaryFolder folder;
  CalibrationTargetDescription flat;
  flat.kind = Kind::kCheckerboard;
  flat.on_table = true;
  const fs::path listed = MakeCapture(folder / "flat");
  WriteCalibrationTarget(listed, flat);
  const fs::path pose = MakeCapture(folder / "pose");
  DescribeTargetsOptions options;
  options.kind = Kind::kCheckerboard;
  const auto described = DescribeTargetSessions(options, {pose}, {listed, pose});
  ASSERT_EQ(described.size(), 1u);
  EXPECT_EQ(described[0].what, "a tilted board pose");
  const CalibrationTargetDescription written = LoadCalibrationTarget(pose);
  EXPECT_FALSE(written.on_table);
  EXPECT_EQ(written.checkerboard.inner_corners_x, CheckerboardTarget().inner_corners_x);

  // Without it, the first is the board on the table.
  const fs::path first = MakeCapture(folder / "first");
  EXPECT_EQ(DescribeTargetSessions(options, {first})[0].what, "the board lying on the table");
  EXPECT_TRUE(LoadCalibrationTarget(first).on_table);
}

TEST(CalibrationTargetTest, RefusesAFolderWithoutSessionAndABadSpacerByName) {
  TemporaryFolder folder;
  fs::create_directories(folder / "empty");
  DescribeTargetsOptions options;
  options.kind = Kind::kGrayChart;
  EXPECT_THAT([&] { DescribeTargetSessions(options, {folder / "empty"}); },
              ThrowsMessage<SessionError>(HasSubstr((folder / "empty").string() + " holds no session.json")));
  EXPECT_FALSE(fs::exists(folder / "empty" / kCalibrationTargetFileName));
  options.spacer_mm = 0;
  EXPECT_THAT([&] { DescribeTargetSessions(options, {}); },
              ThrowsMessage<std::invalid_argument>(HasSubstr("spacer_mm = 0 must lie in (0, 200] mm")));
}

}  // namespace
}  // namespace scanbench
