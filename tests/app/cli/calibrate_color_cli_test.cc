// `scanbench calibrate color` through the real binary on single RAW photos
// (issue #12): a photo of a ColorChecker under one light starts a calibration
// set of its camera, balanced on the chart's gray row; a photo without a chart
// fails naming the file, and writes nothing.
#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/session/calibration_set.h"
#include "tests/util/command_runner.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

TEST(CalibrateColorCliTest, HelpListsEveryOption) {
  const CommandResult help = RunScanbench("calibrate color --help");
  EXPECT_EQ(help.exit_code, 0);
  for (const char* option : {"targets", "--output", "--method", "ciede2000", "opencv-ccm", "--corners", "--no-verify"}) {
    EXPECT_THAT(help.output, HasSubstr(option));
  }
}

TEST(CalibrateColorCliTest, APhotoOfTheChartStartsASetAndAPhotoWithoutOneFails) {
  testing::TemporaryFolder folder;
  const std::string size = " --width 616 --height 408";
  const CommandResult chart = RunScanbench("simulate " + Quoted(folder / "chart") + " --sample colorchecker" + size);
  ASSERT_EQ(chart.exit_code, 0) << chart.output;
  const CommandResult twill = RunScanbench("simulate " + Quoted(folder / "twill") + size);
  ASSERT_EQ(twill.exit_code, 0) << twill.output;
  // Photos under foreign names, as a card reader leaves them: LED 6 is on the
  // upper ring, which lights the chart evenly enough for one photo.
  fs::copy_file(folder / "chart" / "frames" / "led_06.dng", folder / "DSC_0042.DNG");
  fs::copy_file(folder / "twill" / "frames" / "led_06.dng", folder / "DSC_0043.DNG");

  const fs::path set = folder / "photo_set";
  const CommandResult fit = RunScanbench("calibrate color " + Quoted(folder / "DSC_0042.DNG") + " -o " + Quoted(set));
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  EXPECT_THAT(fit.output, HasSubstr("Colour chart detection (mcc): success"));
  EXPECT_THAT(fit.output, HasSubstr("the chart's gray row per frame (relative"));
  EXPECT_THAT(fit.output, HasSubstr("cyan"));
  const CalibrationSet loaded = LoadCalibrationSet(set);
  ASSERT_TRUE(loaded.color.has_value());
  EXPECT_EQ(loaded.color->white_reference, "neutral_patches");
  ASSERT_EQ(loaded.color->raw_files.size(), 1u);
  EXPECT_EQ(loaded.color->raw_files[0].sha256.size(), 64u);
  EXPECT_EQ(loaded.camera.width, 616);
  EXPECT_FALSE(loaded.camera_calibration.has_value());
  const ColorCorrectionSummary& s = loaded.color->summary;
  ASSERT_EQ(s.patches.size(), 24u);
  EXPECT_EQ(s.patches.front().name, "dark skin");  // found in chart order
  EXPECT_EQ(s.patches.back().name, "black 2 (1.5 D)");
  EXPECT_GE(s.used_patches, 20);
  EXPECT_GT(s.mean_delta_e_before, 4.0);
  // One LED lights the chart unevenly, which the photo's gray-row balance
  // cannot undo (a chart session through the light calibration can): still a
  // fraction of the uncorrected error.
  EXPECT_LT(s.mean_delta_e_after, 3.0);
  EXPECT_LT(s.mean_delta_e_after, 0.5 * s.mean_delta_e_before);

  const fs::path none = folder / "no_set";
  const CommandResult fail = RunScanbench("calibrate color " + Quoted(folder / "DSC_0043.DNG") + " -o " + Quoted(none));
  EXPECT_EQ(fail.exit_code, 1);
  EXPECT_THAT(fail.output, HasSubstr("DSC_0043.DNG"));
  EXPECT_THAT(fail.output, HasSubstr("no ColorChecker found"));
  EXPECT_FALSE(fs::exists(none));
  // A photo of another camera size cannot join the set.
  const CommandResult small = RunScanbench("simulate " + Quoted(folder / "small") + " --sample colorchecker --width 500 --height 330");
  ASSERT_EQ(small.exit_code, 0) << small.output;
  const CommandResult other = RunScanbench("calibrate color " + Quoted(folder / "small" / "frames" / "led_06.dng") + " -o " + Quoted(set));
  EXPECT_EQ(other.exit_code, 1);
  EXPECT_THAT(other.output, HasSubstr("a colour calibration serves one camera"));
}

// Issue #36 item 14: a later `calibrate white` (or `lights`) into a set whose
// colour section was measured through the light field marks it stale: the
// command says so with the refit command, a solve with the set reports it, and
// a refit clears it.
TEST(CalibrateColorCliTest, ALaterWhiteBalanceMarksTheColourSectionStale) {
  testing::TemporaryFolder folder;
  const fs::path demo = folder / "demo";
  const CommandResult made = RunScanbench("calibrate demo --output " + Quoted(demo) + " --width 308 --height 204");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  const fs::path cal = demo / "calibration";
  const fs::path targets = demo / "targets";
  const std::string solve = "solve " + Quoted(demo / "colorchecker_scan") + " --calibration " + Quoted(cal);
  const CommandResult fresh = RunScanbench(solve);
  ASSERT_EQ(fresh.exit_code, 0) << fresh.output;
  EXPECT_THAT(fresh.output, ::testing::Not(HasSubstr("stale")));

  const CommandResult white = RunScanbench("calibrate white " + Quoted(targets / "gray_chart") + " -c " + Quoted(cal));
  ASSERT_EQ(white.exit_code, 0) << white.output;
  EXPECT_THAT(white.output, HasSubstr("warning: " + (cal / "calibration.json").string() + ": color: stale:"));
  EXPECT_THAT(white.output, HasSubstr("refit it: scanbench calibrate color " + (targets / "color_chart").string()));
  const CommandResult stale = RunScanbench(solve);
  ASSERT_EQ(stale.exit_code, 0) << stale.output;
  EXPECT_THAT(stale.output, HasSubstr("color: stale"));

  const CommandResult refit =
      RunScanbench("calibrate color " + Quoted(targets / "color_chart") + " -o " + Quoted(cal));
  ASSERT_EQ(refit.exit_code, 0) << refit.output;
  const CommandResult again = RunScanbench(solve);
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_THAT(again.output, ::testing::Not(HasSubstr("stale")));
}

}  // namespace
}  // namespace scanbench
