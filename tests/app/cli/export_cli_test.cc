// `scanbench export` and the demo's export, run as a user runs them.

#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/util/command_runner.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::vector<fs::path> Subfolders(const fs::path& folder) {
  std::vector<fs::path> folders;
  if (!fs::exists(folder)) return folders;
  for (const auto& entry : fs::directory_iterator(folder)) {
    if (entry.is_directory()) folders.push_back(entry.path());
  }
  std::sort(folders.begin(), folders.end());
  return folders;
}

TEST(ExportCliTest, ExportsASolvedSessionWithTheChosenPresetAndConvention) {
  testing::TemporaryFolder folder;
  const fs::path session = folder / "s";
  ASSERT_EQ(RunScanbench("simulate " + Quoted(session) + " --width 320 --height 212").exit_code, 0);
  ASSERT_EQ(RunScanbench("solve " + Quoted(session)).exit_code, 0);
  const std::vector<fs::path> results = Subfolders(session / "results");
  ASSERT_EQ(results.size(), 1u);

  const CommandResult exported =
      RunScanbench("export " + Quoted(results[0]) +
                   " --preset tiff16 --normal-convention directx --material denim --tileable --tile-size 64"
                   " --height-method dct --gloss-model ggx");
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  EXPECT_THAT(exported.output, HasSubstr("scanbench export report"));
  EXPECT_THAT(exported.output, HasSubstr("denim (tiff16, normals directx -Y)"));
  EXPECT_THAT(exported.output, HasSubstr("height RMS error"));
  EXPECT_THAT(exported.output, HasSubstr("write files      100%")) << "progress is shown";
  const std::vector<fs::path> exports = Subfolders(session / "exports");
  ASSERT_EQ(exports.size(), 1u);
  EXPECT_EQ(exports[0].filename().string(), results[0].filename().string() + "-tiff16");
  for (const char* name : {"denim_basecolor.tif", "denim_normal.tif", "denim_height.exr", "denim_height_normalized.tif",
                           "denim_ao.tif", "denim_cavity.tif", "denim_roughness_mip00.tif",
                           "denim_basecolor_srgb_preview.png", "denim_mask.png", "denim_tile_normal.tif"}) {
    EXPECT_TRUE(fs::is_regular_file(exports[0] / "denim" / name)) << name;
  }
  std::ifstream manifest_file(exports[0] / "material.json");
  const nlohmann::json manifest = nlohmann::json::parse(manifest_file);
  EXPECT_EQ(manifest["normal_convention"], "directx");
  EXPECT_EQ(manifest["options"]["gloss"]["model"], "ggx");
  EXPECT_EQ(manifest["files"]["tile_normal"]["width"], 64);
  EXPECT_TRUE(fs::is_regular_file(exports[0] / "preview.html")) << "written by default";
  EXPECT_EQ(manifest["files"]["preview"]["path"], "preview.html");
  EXPECT_THAT(exported.output, HasSubstr("preview page: preview.html: "));

  // Given scale, no flattening, into another folder.
  const CommandResult scaled = RunScanbench("export " + Quoted(results[0]) + " --preset exr --mm-per-pixel 0.2" +
                                            " --no-flatten --height-method dct --no-preview --output " +
                                            Quoted(folder / "out"));
  ASSERT_EQ(scaled.exit_code, 0) << scaled.output;
  EXPECT_THAT(scaled.output, HasSubstr("0.200000 mm per pixel (options)"));
  EXPECT_THAT(scaled.output, HasSubstr("flattening:   off"));
  ASSERT_EQ(Subfolders(folder / "out").size(), 1u);
  EXPECT_FALSE(fs::exists(Subfolders(folder / "out")[0] / "preview.html")) << "--no-preview";

  // An engine preset: its names and its normal convention, whatever was asked.
  std::string engine_export = "export " + Quoted(results[0]);
  engine_export += " --preset unreal --normal-convention opengl --material denim --output ";
  engine_export += Quoted(folder / "engine");
  const CommandResult unreal = RunScanbench(engine_export);
  ASSERT_EQ(unreal.exit_code, 0) << unreal.output;
  EXPECT_THAT(unreal.output, HasSubstr("denim (unreal, normals directx -Y)"));
  const std::vector<fs::path> engine = Subfolders(folder / "engine");
  ASSERT_EQ(engine.size(), 1u);
  for (const char* name : {"T_denim_BC.png", "T_denim_N.png", "T_denim_ORM.png", "T_denim_H.png", "denim.mtlx"}) {
    EXPECT_TRUE(fs::is_regular_file(engine[0] / "denim" / name)) << name;
  }
}

TEST(ExportCliTest, BadArgumentsExitNonZeroNamingTheProblem) {
  testing::TemporaryFolder folder;
  const CommandResult bad_preset = RunScanbench("export " + Quoted(folder.path()) + " --preset jpeg");
  EXPECT_NE(bad_preset.exit_code, 0);
  EXPECT_THAT(bad_preset.output, HasSubstr("'jpeg' must be exr, png16, tiff16, unreal, unity-hdrp or gltf"));
  const CommandResult bad_convention = RunScanbench("export " + Quoted(folder.path()) + " --normal-convention up");
  EXPECT_NE(bad_convention.exit_code, 0);
  EXPECT_THAT(bad_convention.output, HasSubstr("'up' must be opengl or directx"));
  const CommandResult not_a_result = RunScanbench("export " + Quoted(folder.path()));
  EXPECT_EQ(not_a_result.exit_code, 1);
  EXPECT_THAT(not_a_result.output, HasSubstr("is not a result folder"));
  EXPECT_NE(RunScanbench("export /nonexistent/results/x").exit_code, 0);
  EXPECT_EQ(RunScanbench("export --help").exit_code, 0);
}

TEST(ExportCliTest, DemoExportsTheDerivedMaps) {
  testing::TemporaryFolder folder;
  const CommandResult demo = RunScanbench("demo --width 320 --height 212 --output " + Quoted(folder / "demo"));
  ASSERT_EQ(demo.exit_code, 0) << demo.output;
  EXPECT_THAT(demo.output, HasSubstr("normal angular error vs ground truth"));
  EXPECT_THAT(demo.output, HasSubstr("(png16, normals opengl +Y)"));
  EXPECT_THAT(demo.output, HasSubstr("vs ground truth on the sample: height RMS error"));
  const std::vector<fs::path> exports = Subfolders(folder / "demo" / "session" / "exports");
  ASSERT_EQ(exports.size(), 1u);
  EXPECT_TRUE(fs::is_regular_file(exports[0] / "material.json"));
  EXPECT_TRUE(fs::is_regular_file(exports[0] / "simulated_twill" / "simulated_twill_normal.png"));
  EXPECT_TRUE(fs::is_regular_file(exports[0] / "preview.html"));

  const CommandResult solve_only =
      RunScanbench("demo --width 320 --height 212 --no-export --output " + Quoted(folder / "demo"));
  ASSERT_EQ(solve_only.exit_code, 0) << solve_only.output;
  EXPECT_EQ(Subfolders(folder / "demo" / "session" / "exports").size(), 1u) << "--no-export stops after the solve";
}

}  // namespace
}  // namespace scanbench
