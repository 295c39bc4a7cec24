// The export's one table of what each file holds (app/io/export_contents.h):
// what every preset's export actually writes (material.json's basecolor
// encoding, the base colour file's colour space and its values against the
// result's linear albedo), and that the CLI's help and docs/export.md state
// the table. The GUI's dialog is checked in tests/app/gui/export_dialog_test.cc.
#include "app/io/export_contents.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

#include <nlohmann/json.hpp>

#include "app/controllers/export_controller.h"
#include "app/controllers/simulate_controller.h"
#include "app/controllers/solve_controller.h"
#include "app/io/image_io.h"
#include "calibration/color_science.h"
#include "tests/util/command_runner.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// Runs of whitespace as one space: the help may be wrapped to the terminal.
std::string OneLine(const std::string& text) { return std::regex_replace(text, std::regex("\\s+"), " "); }

TEST(ExportContentsTest, EveryPresetOnceAndKnownToTheExport) {
  std::vector<std::string> names;
  for (const ExportPresetContents& row : ExportPresetContentsTable()) {
    names.push_back(row.name);
    EXPECT_EQ(ExportPresetName(ExportPresetFromName(row.name)), std::string(row.name));
    EXPECT_EQ(&ExportPresetContentsOf(row.name), &row);
  }
  EXPECT_EQ(names, (std::vector<std::string>{"png16", "tiff16", "exr", "unreal", "unity-hdrp", "gltf"}));
  EXPECT_EQ(ExportPresetContentsTable().front().name, std::string(ExportPresetName(ExportOptions().preset)))
      << "the table lists the default first";
  EXPECT_THROW(ExportPresetContentsOf("jpeg"), std::invalid_argument);
  // Issue #36: the integer presets' base colour is sRGB-encoded, and says so.
  for (const char* name : {"png16", "tiff16"}) {
    const ExportPresetContents& row = ExportPresetContentsOf(name);
    EXPECT_TRUE(row.basecolor_srgb) << name;
    EXPECT_THAT(ExportPresetHolds(row), HasSubstr("base colour 16-bit, sRGB-encoded")) << name;
    EXPECT_THAT(ExportPresetHolds(row), HasSubstr("normals 16-bit, linear")) << name;
  }
  EXPECT_FALSE(ExportPresetContentsOf("exr").basecolor_srgb);
}

class ExportContentsExportTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    folder_ = new testing::TemporaryFolder;
    const fs::path session = *folder_ / "s";
    SimulateOptions simulate;
    simulate.rig.width = 96;
    simulate.rig.height = 64;
    SimulateController(session, simulate).Run();
    SolveController solve(session, SolveOptions());
    solve.Run();
    result_ = solve.summary().result_dir;
  }
  static void TearDownTestSuite() {
    delete folder_;
    folder_ = nullptr;
  }
  static inline testing::TemporaryFolder* folder_ = nullptr;
  static inline fs::path result_;
};

// Each preset's export writes what the table says: material.json's encoding,
// the base colour file's colour space, and its stored values are
// srgb(albedo) or the albedo itself.
TEST_F(ExportContentsExportTest, WhatEachPresetWritesIsTheTables) {
  const ImageF albedo = ReadImageFloat(result_ / "albedo.exr");
  for (const ExportPresetContents& row : ExportPresetContentsTable()) {
    SCOPED_TRACE(row.name);
    ExportOptions options;
    options.preset = ExportPresetFromName(row.name);
    options.preview_page = false;
    options.output_root = *folder_ / "exports" / row.name;
    ExportController exporter(result_, options);
    exporter.Run();
    const fs::path dir = exporter.summary().export_dir;
    std::ifstream in(dir / "material.json");
    const nlohmann::json manifest = nlohmann::json::parse(in);
    EXPECT_EQ(manifest["basecolor"]["encoding"], BasecolorEncodingName(row));
    const nlohmann::json& file = manifest["files"]["basecolor"];
    EXPECT_EQ(file["color_space"], row.basecolor_srgb ? "sRGB" : "Linear");
    const ImageF stored = ReadImageFloat(dir / file["path"].get<std::string>());
    ASSERT_TRUE(stored.SameSize(albedo));
    const double step = file["sample_type"] == "float" ? 1e-3 : 1.0 / ((1 << file["bits_per_sample"].get<int>()) - 1);
    int compared = 0;
    double worst = 0;
    for (int y = 0; y < albedo.height(); ++y) {
      for (int x = 0; x < albedo.width(); ++x) {
        const double value = albedo(x, y, 1);
        if (value < 0.05 || value > 0.9) continue;
        const double expected = row.basecolor_srgb ? SrgbEncode(value) : value;
        worst = std::max(worst, std::abs(stored(x, y, 1) - expected));
        ++compared;
      }
    }
    EXPECT_GT(compared, 100);
    EXPECT_LE(worst, step) << "the base colour file does not hold " << (row.basecolor_srgb ? "srgb(albedo)" : "the albedo");
  }
}

TEST(ExportContentsTest, TheCliHelpStatesTheTable) {
  const CommandResult help = RunScanbench("export --help");
  ASSERT_EQ(help.exit_code, 0) << help.output;
  const std::string text = OneLine(help.output);
  for (const ExportPresetContents& row : ExportPresetContentsTable()) {
    EXPECT_THAT(text, HasSubstr(OneLine(std::string(row.name) + (row.name == std::string("png16") ? " (default)" : "") +
                                        ": " + row.format + ", " + ExportPresetHolds(row))));
  }
}

TEST(ExportContentsTest, TheDocsStateTheTable) {
  const std::string path = std::string(SCANBENCH_SOURCE_DIR) + "/docs/export.md";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  std::stringstream docs;
  docs << in.rdbuf();
  EXPECT_NE(docs.str().find(ExportPresetMarkdownTable()), std::string::npos)
      << path << ": its \"## Presets\" table is not app/io/export_contents.h's; paste ExportPresetMarkdownTable():\n"
      << ExportPresetMarkdownTable();
}

}  // namespace
}  // namespace scanbench
