// `scanbench import`, `bench init` and the rig template's first step on a
// real bench, run as a user runs them.
#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/io/file_util.h"
#include "app/session/rig_json.h"
#include "app/session/session.h"
#include "tests/util/command_runner.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kTemplate = fs::path(SCANBENCH_SOURCE_DIR) / "data" / "bench" / "d5100_10led_rig.json";

TEST(ImportCliTest, ImportsACardFolderByPatternAndSolvesIt) {
  testing::TemporaryFolder folder;
  const fs::path original = folder / "original";
  ASSERT_EQ(RunScanbench("simulate " + Quoted(original) + " --width 240 --height 160").exit_code, 0);
  const Session session = LoadSession(original);
  {
    std::ofstream rig(folder / "bench.json");
    rig << RigDescriptionToJson(session.rig);
  }
  // Names as a tethering tool writes them, 1-based LEDs shifted into a pattern.
  fs::create_directories(folder / "card");
  fs::copy_file(original / FindDarkFrame(session)->file, folder / "card" / "scan_dark.dng");
  for (int k = 0; k < 10; ++k) {
    fs::copy_file(original / FindLedFrame(session, k)->file, folder / "card" / ("scan_L" + std::to_string(k) + ".dng"));
  }
  const CommandResult imported =
      RunScanbench("import " + Quoted(folder / "card") + " " + Quoted(folder / "imported") + " --rig " +
                   Quoted(folder / "bench.json") + " --pattern 'scan_L{led}' --dark scan_dark.dng");
  ASSERT_EQ(imported.exit_code, 0) << imported.output;
  EXPECT_THAT(imported.output, HasSubstr("11 frames copied, 0 already there"));
  EXPECT_THAT(imported.output, HasSubstr("led_07 <- " + (folder / "card" / "scan_L7.dng").string()));
  EXPECT_THAT(imported.output, HasSubstr("copy             100%")) << "progress is shown";
  EXPECT_EQ(LoadSession(folder / "imported").sample_name, "card") << "the folder's name by default";
  const CommandResult solved = RunScanbench("solve " + Quoted(folder / "imported"));
  EXPECT_EQ(solved.exit_code, 0) << solved.output;
  EXPECT_THAT(solved.output, HasSubstr("success"));

  // Refused, exit code 1, naming the file: a JPEG among the RAWs.
  std::ofstream(folder / "card" / "scan_L3.jpg") << "\xFF\xD8\xFF\xE0 not really";
  fs::remove(folder / "card" / "scan_L3.dng");
  const CommandResult refused =
      RunScanbench("import " + Quoted(folder / "card") + " " + Quoted(folder / "again") + " --rig " +
                   Quoted(folder / "bench.json") + " --pattern 'scan_L{led}' --dark scan_dark.dng");
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_THAT(refused.output, HasSubstr((folder / "card" / "scan_L3.jpg").string() + ": is a JPEG"));
  EXPECT_FALSE(fs::exists(folder / "again"));
}

TEST(ImportCliTest, BenchInitWritesTheTemplateAndRefusesToOverwrite) {
  testing::TemporaryFolder folder;
  const CommandResult made = RunScanbench("bench init " + Quoted(folder / "bench.json"));
  ASSERT_EQ(made.exit_code, 0) << made.output;
  EXPECT_THAT(made.output, HasSubstr("leds[0..9].position_in_table_mm"));
  // data/bench's template is exactly what the defaults give.
  EXPECT_EQ(ReadFileBytes(folder / "bench.json"), ReadFileBytes(kTemplate))
      << "regenerate it: scanbench bench init " << kTemplate.string() << " --force";
  EXPECT_EQ(RunScanbench("bench init " + Quoted(folder / "bench.json")).exit_code, 1);

  const CommandResult six = RunScanbench("bench init " + Quoted(folder / "six.json") +
                                         " --leds 6 --ring-radii-mm 300 --ring-heights-mm 300 --camera-height-mm 700");
  ASSERT_EQ(six.exit_code, 0) << six.output;
  const RigDescription rig = LoadRigDescriptionFile((folder / "six.json").string());
  EXPECT_EQ(rig.leds.size(), 6u);
  EXPECT_NEAR(rig.camera.cam_from_table.translation().z(), 700, 1e-9);
  const CommandResult bad = RunScanbench("bench init " + Quoted(folder / "bad.json") +
                                         " --ring-radii-mm 300,200 --ring-heights-mm 300");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_THAT(bad.output, HasSubstr("--ring-heights-mm 1 values: must have one height per ring radius (2)"));
}

// The first step on the real bench with the template: everything up to the
// LED board, then a message saying what to connect.
TEST(ImportCliTest, CaptureOnHardwareWithTheTemplateStopsAtTheLedBoard) {
  testing::TemporaryFolder folder;
  const CommandResult capture = RunScanbench("capture " + Quoted(folder / "s") + " --rig hardware --rig-file " +
                                             Quoted(kTemplate) + " --sample-name first");
  EXPECT_EQ(capture.exit_code, 1);
  EXPECT_THAT(capture.output, HasSubstr("no LED board found"));
  EXPECT_THAT(capture.output, HasSubstr("Connect the LED board, an Arduino Uno flashed with firmware/"));
  EXPECT_FALSE(fs::exists(folder / "s"));
}

}  // namespace
}  // namespace scanbench
