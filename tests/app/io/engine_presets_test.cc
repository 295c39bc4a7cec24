// Engine presets of the export (issue #16) on a simulated session: each
// preset's files read back by their engine's conventions (names, channel
// layout, ranges, colour spaces, the DirectX / OpenGL green channel), the
// glTF tile checked against its maps and by the Khronos glTF-Validator, and
// the MaterialX document of every preset parsed as XML and checked against
// the standard library's node signatures.
#include "app/io/engine_presets.h"

#include <expat.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iostream>
#include <fstream>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/controllers/export_controller.h"
#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "calibration/color_science.h"
#include "tests/util/command_runner.h"
#include "tests/util/solved_session.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::ReadJsonFile;
using testing::TemporaryFolder;

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// --- The packing on its own ---------------------------------------------------

TEST(EnginePackingTest, OrmAndMaskMapHoldTheirChannels) {
  ImageF occlusion(3, 2, 1), alpha(3, 2, 1);
  const float ao_values[] = {1.0f, 0.8f, 0.5f, 0.25f, 0.0f, 0.9f};
  const float alpha_values[] = {0.0f, 0.04f, 0.25f, 0.49f, 1.0f, 0.09f};
  for (int i = 0; i < 6; ++i) {
    occlusion.data()[i] = ao_values[i];
    alpha.data()[i] = alpha_values[i];
  }
  const ImageF orm = PackOcclusionRoughnessMetallic(occlusion, alpha);
  const ImageF mask = PackHdrpMaskMap(occlusion, alpha);
  ASSERT_EQ(orm.channels(), 3);
  ASSERT_EQ(mask.channels(), 4);
  for (int i = 0; i < 6; ++i) {
    SCOPED_TRACE(i);
    const float perceptual = std::sqrt(alpha_values[i]);  // 0, 0.2, 0.5, 0.7, 1, 0.3
    EXPECT_FLOAT_EQ(orm.data()[3 * i + 0], ao_values[i]);
    EXPECT_FLOAT_EQ(orm.data()[3 * i + 1], perceptual);
    EXPECT_FLOAT_EQ(orm.data()[3 * i + 2], 0.0f);
    EXPECT_FLOAT_EQ(mask.data()[4 * i + 0], 0.0f);
    EXPECT_FLOAT_EQ(mask.data()[4 * i + 1], ao_values[i]);
    EXPECT_FLOAT_EQ(mask.data()[4 * i + 2], 1.0f);
    EXPECT_FLOAT_EQ(mask.data()[4 * i + 3], 1.0f - perceptual);
  }
  EXPECT_FLOAT_EQ(PerceptualRoughnessFromGgxAlpha(alpha).data()[3], 0.7f);
  try {
    PackHdrpMaskMap(occlusion, ImageF(2, 2, 1));
    FAIL() << "sizes differ";
  } catch (const std::invalid_argument& error) {
    EXPECT_THAT(error.what(), HasSubstr("3x2x1"));
    EXPECT_THAT(error.what(), HasSubstr("2x2x1"));
  }
  EXPECT_EQ(EngineTextureNamesOf(EngineTarget::kUnreal, "twill").packed, "T_twill_ORM.png");
  EXPECT_EQ(EngineTextureNamesOf(EngineTarget::kUnityHdrp, "twill").packed, "twill_MaskMap.png");
  EXPECT_TRUE(EngineNormalIsDirectX(EngineTarget::kUnreal));
  EXPECT_FALSE(EngineNormalIsDirectX(EngineTarget::kGltf));
}

// --- Exports of one simulated session ------------------------------------------

// One small simulated and solved session, exported once per preset (about 5 s).
class EnginePresetExportTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    folder_ = new TemporaryFolder();
    result_dir_ = new fs::path(testing::SimulateAndSolve(*folder_ / "session", 400, 264, "test twill"));
    exports_ = new std::map<std::string, ExportSummary>;
    for (const auto preset : {ExportOptions::Preset::kPng16, ExportOptions::Preset::kLinearExr,
                              ExportOptions::Preset::kUnreal, ExportOptions::Preset::kUnityHdrp,
                              ExportOptions::Preset::kGltf}) {
      ExportOptions options;
      options.preset = preset;
      options.output_root = *folder_ / "exports";
      ExportController controller(*result_dir_, options);
      controller.Run();
      (*exports_)[ExportPresetName(preset)] = controller.summary();
    }
    ExportOptions displaced;
    displaced.preset = ExportOptions::Preset::kGltf;
    displaced.gltf_displaced_mesh = true;
    displaced.gltf_mesh_max_vertices = 5000;
    displaced.output_root = *folder_ / "exports";
    ExportController controller(*result_dir_, displaced);
    controller.Run();
    (*exports_)["gltf-displaced"] = controller.summary();
  }
  static void TearDownTestSuite() {
    delete exports_;
    delete result_dir_;
    delete folder_;
  }
  static const ExportSummary& Of(const std::string& preset) { return exports_->at(preset); }
  static fs::path FileOf(const std::string& preset, const std::string& kind) {
    return Of(preset).export_dir / Of(preset).files.at(kind);
  }

  static TemporaryFolder* folder_;
  static fs::path* result_dir_;
  static std::map<std::string, ExportSummary>* exports_;
};

TemporaryFolder* EnginePresetExportTest::folder_ = nullptr;
fs::path* EnginePresetExportTest::result_dir_ = nullptr;
std::map<std::string, ExportSummary>* EnginePresetExportTest::exports_ = nullptr;

uint16_t Quantised(double value) { return static_cast<uint16_t>(std::lround(std::clamp(value, 0.0, 1.0) * 65535)); }

TEST_F(EnginePresetExportTest, EveryEngineFileIsListedWithItsLayoutAndColourSpace) {
  for (const std::string preset : {"unreal", "unity-hdrp", "gltf"}) {
    SCOPED_TRACE(preset);
    const ExportSummary& summary = Of(preset);
    EXPECT_EQ(summary.export_dir.filename().string(), result_dir_->filename().string() + "-" + preset);
    const nlohmann::json manifest = ReadJsonFile(summary.export_dir / "material.json");
    EXPECT_EQ(manifest["preset"], preset);
    EXPECT_EQ(manifest["normal_convention"], preset == "unreal" ? "directx" : "opengl");
    EXPECT_THAT(manifest["engine"]["roughness"].get<std::string>(), HasSubstr("sqrt(GGX alpha)"));
    EXPECT_EQ(manifest["files"].count("basecolor_srgb_preview"), 0u) << "the base colour is 8-bit sRGB itself";
    EXPECT_EQ(manifest["files"].count("roughness_mip01"), 0u) << "engines make their own mips";
    for (const auto& [kind, entry] : manifest["files"].items()) {
      SCOPED_TRACE(kind);
      const fs::path path = summary.export_dir / entry["path"].get<std::string>();
      ASSERT_TRUE(fs::is_regular_file(path));
      EXPECT_EQ(Sha256HexOfFile(path), entry["sha256"]);
      EXPECT_EQ(fs::file_size(path), entry["bytes"].get<uintmax_t>());
      if (!entry.contains("bits_per_sample")) continue;  // a document (.mtlx, .gltf, .bin)
      const ImageFileInfo info = ReadImageFileInfo(path);
      EXPECT_EQ(info.bits_per_sample, entry["bits_per_sample"]);
      EXPECT_EQ(info.channels, entry["channels"]);
      EXPECT_EQ(info.width, 400);
      EXPECT_EQ(info.metadata.color_space, entry["color_space"]);
      EXPECT_EQ(info.metadata.color_space, kind == "basecolor" ? "sRGB" : "Raw");
      EXPECT_EQ(info.metadata.attributes.at("scanbench:map"), kind);
    }
    EXPECT_EQ(manifest["files"]["basecolor"]["bits_per_sample"], 8);
    EXPECT_EQ(manifest["files"]["normal"]["bits_per_sample"], 16);
    EXPECT_EQ(manifest["files"]["height"]["format"], "exr");
    EXPECT_EQ(manifest["files"]["materialx"]["format"], "mtlx");
  }
  EXPECT_EQ(Of("unreal").files.at("basecolor"), "test_twill/T_test_twill_BC.png");
  EXPECT_EQ(Of("unreal").files.at("normal"), "test_twill/T_test_twill_N.png");
  EXPECT_EQ(Of("unreal").files.at("orm"), "test_twill/T_test_twill_ORM.png");
  EXPECT_EQ(Of("unreal").files.at("height_normalized"), "test_twill/T_test_twill_H.png");
  EXPECT_EQ(Of("unity-hdrp").files.at("basecolor"), "test_twill/test_twill_BaseMap.png");
  EXPECT_EQ(Of("unity-hdrp").files.at("normal"), "test_twill/test_twill_Normal.png");
  EXPECT_EQ(Of("unity-hdrp").files.at("mask_map"), "test_twill/test_twill_MaskMap.png");
  EXPECT_EQ(Of("unity-hdrp").files.at("height_normalized"), "test_twill/test_twill_HeightMap.png");
  EXPECT_EQ(Of("gltf").files.at("basecolor"), "test_twill/test_twill_baseColor.png");
  EXPECT_EQ(Of("gltf").files.at("occlusion_roughness_metallic"), "test_twill/test_twill_occlusionRoughnessMetallic.png");
  EXPECT_EQ(Of("gltf").files.at("gltf"), "test_twill/test_twill.gltf");
  EXPECT_EQ(Of("gltf").files.at("gltf_buffer"), "test_twill/test_twill.bin");
}

TEST_F(EnginePresetExportTest, BaseColourIsTheAlbedoThroughTheSrgbCurveIn8Bits) {
  const ImageF albedo = ReadImageFloat(*result_dir_ / "albedo.exr");
  for (const std::string preset : {"unreal", "unity-hdrp", "gltf"}) {
    SCOPED_TRACE(preset);
    const ImageU8 basecolor = ReadImageU8(FileOf(preset, "basecolor"));
    ASSERT_EQ(basecolor.channels(), 3);
    for (const auto& [x, y] : {std::pair{200, 130}, std::pair{90, 60}, std::pair{310, 200}}) {
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(basecolor(x, y, c), SrgbEncode(std::clamp<double>(albedo(x, y, c), 0.0, 1.0)) * 255.0, 0.51);
      }
    }
    EXPECT_EQ(ReadImageMetadata(FileOf(preset, "basecolor")).attributes.at("scanbench:albedo_color_space"),
              "linear_rec709");
  }
}

TEST_F(EnginePresetExportTest, UnrealNormalsAreDirectXAndTheOthersOpenGl) {
  const ImageU16 opengl = ReadImageU16(FileOf("png16", "normal"));
  for (const std::string preset : {"unreal", "unity-hdrp", "gltf"}) {
    SCOPED_TRACE(preset);
    const ImageU16 normal = ReadImageU16(FileOf(preset, "normal"));
    ASSERT_TRUE(normal.SameSize(opengl));
    ASSERT_EQ(normal.channels(), 3);
    int max_green = 0, max_other = 0;
    for (size_t i = 0; i < normal.num_pixels(); ++i) {
      const int green = normal.data()[3 * i + 1], green_gl = opengl.data()[3 * i + 1];
      max_green = std::max(max_green, preset == "unreal" ? std::abs(green + green_gl - 65535) : std::abs(green - green_gl));
      for (int c : {0, 2}) max_other = std::max(max_other, std::abs(normal.data()[3 * i + c] - opengl.data()[3 * i + c]));
    }
    EXPECT_LE(max_green, preset == "unreal" ? 1 : 0) << "unreal: G = 65535 - G_opengl; others: G = G_opengl";
    EXPECT_EQ(max_other, 0);
    EXPECT_EQ(ReadImageMetadata(FileOf(preset, "normal")).attributes.at("scanbench:normal_convention"),
              preset == "unreal" ? "directx" : "opengl");
  }
  // A bump's upper flank tilts towards the image top (+y in the solver frame):
  // OpenGL green above mid-grey there means DirectX green below it.
  const ImageU16 unreal = ReadImageU16(FileOf("unreal", "normal"));
  size_t up = 0, unreal_down = 0;
  for (size_t i = 0; i < opengl.num_pixels(); ++i) {
    if (opengl.data()[3 * i + 1] > 32768 + 3000) {
      ++up;
      unreal_down += unreal.data()[3 * i + 1] < 32767 - 2900;
    }
  }
  ASSERT_GT(up, 100u);
  EXPECT_EQ(unreal_down, up);
}

TEST_F(EnginePresetExportTest, PackedMapsHoldOcclusionAndPerceptualRoughness) {
  const ImageF ao = ReadImageFloat(FileOf("exr", "ao"));
  const ImageF alpha = ReadImageFloat(FileOf("exr", "roughness_mip00"));
  const ImageU16 orm = ReadImageU16(FileOf("unreal", "orm"));
  const ImageU16 gltf = ReadImageU16(FileOf("gltf", "occlusion_roughness_metallic"));
  const ImageU16 mask = ReadImageU16(FileOf("unity-hdrp", "mask_map"));
  ASSERT_EQ(orm.channels(), 3);
  ASSERT_EQ(mask.channels(), 4);
  ASSERT_TRUE(orm.SameSize(ao.width(), ao.height()));
  const ImageU8 solved = ReadImageU8(FileOf("exr", "mask"));
  int max_error = 0;
  double mean_alpha = 0, mean_perceptual = 0, mean_green = 0;
  size_t solved_pixels = 0;
  for (size_t i = 0; i < orm.num_pixels(); ++i) {
    const uint16_t occlusion = Quantised(ao.data()[i]);
    const uint16_t perceptual = Quantised(std::sqrt(alpha.data()[i]));
    const uint16_t smoothness = Quantised(1.0 - std::sqrt(alpha.data()[i]));
    for (const auto& [stored, expected] :
         {std::pair{orm.data()[3 * i + 0], occlusion}, std::pair{orm.data()[3 * i + 1], perceptual},
          std::pair{orm.data()[3 * i + 2], uint16_t{0}}, std::pair{mask.data()[4 * i + 0], uint16_t{0}},
          std::pair{mask.data()[4 * i + 1], occlusion}, std::pair{mask.data()[4 * i + 2], uint16_t{65535}},
          std::pair{mask.data()[4 * i + 3], smoothness}}) {
      max_error = std::max(max_error, std::abs(int(stored) - int(expected)));
    }
    if (solved.data()[i] == 0) continue;
    ++solved_pixels;
    mean_alpha += alpha.data()[i];
    mean_perceptual += std::sqrt(alpha.data()[i]);
    mean_green += orm.data()[3 * i + 1] / 65535.0;
  }
  EXPECT_LE(max_error, 1);
  ASSERT_GT(solved_pixels, orm.num_pixels() / 2);
  mean_alpha /= solved_pixels;
  mean_perceptual /= solved_pixels;
  mean_green /= solved_pixels;
  // Base roughness alpha 0.3, lower where the solve estimated a specular lobe.
  EXPECT_NEAR(mean_alpha, 0.27, 0.03);
  EXPECT_NEAR(mean_green, mean_perceptual, 1e-4);
  EXPECT_GT(mean_green, mean_alpha + 0.2) << "perceptual roughness sqrt(alpha), not alpha";
  EXPECT_EQ(std::memcmp(orm.data(), gltf.data(), orm.size() * sizeof(uint16_t)), 0) << "glTF packs as Unreal";
  EXPECT_EQ(ReadImageMetadata(FileOf("unity-hdrp", "mask_map")).attributes.at("scanbench:channels"),
            "R metallic = 0, G ambient occlusion, B detail mask = 1, A smoothness = 1 - perceptual roughness");
}

TEST_F(EnginePresetExportTest, GltfTileHasTheSampleSizeAndReferencesItsMaps) {
  const ExportSummary& summary = Of("gltf");
  const fs::path gltf_path = FileOf("gltf", "gltf");
  const nlohmann::json gltf = ReadJsonFile(gltf_path);
  EXPECT_EQ(gltf["asset"]["version"], "2.0");
  const auto image_of_texture = [&](const nlohmann::json& texture_info) {
    const int texture = texture_info["index"];
    const int image = gltf["textures"][texture]["source"];
    return gltf["images"][image]["uri"].get<std::string>();
  };
  const nlohmann::json& material = gltf["materials"][0];
  const nlohmann::json& pbr = material["pbrMetallicRoughness"];
  EXPECT_EQ(pbr["metallicFactor"], 0.0);
  EXPECT_EQ(image_of_texture(pbr["baseColorTexture"]), fs::path(summary.files.at("basecolor")).filename());
  EXPECT_EQ(image_of_texture(material["normalTexture"]), fs::path(summary.files.at("normal")).filename());
  const std::string orm = fs::path(summary.files.at("occlusion_roughness_metallic")).filename();
  EXPECT_EQ(image_of_texture(pbr["metallicRoughnessTexture"]), orm);
  EXPECT_EQ(image_of_texture(material["occlusionTexture"]), orm);
  for (const auto& image : gltf["images"]) {
    EXPECT_TRUE(fs::is_regular_file(gltf_path.parent_path() / image["uri"].get<std::string>()));
  }
  const nlohmann::json& attributes = gltf["meshes"][0]["primitives"][0]["attributes"];
  for (const char* attribute : {"POSITION", "NORMAL", "TANGENT", "TEXCOORD_0"}) EXPECT_TRUE(attributes.contains(attribute));
  const nlohmann::json& position = gltf["accessors"][attributes["POSITION"].get<int>()];
  const double width_m = 400 * summary.mm_per_pixel / 1000, height_m = 264 * summary.mm_per_pixel / 1000;
  EXPECT_NEAR(position["max"][0].get<double>() - position["min"][0].get<double>(), width_m, 1e-7);
  EXPECT_NEAR(position["max"][2].get<double>() - position["min"][2].get<double>(), height_m, 1e-7);
  EXPECT_EQ(position["max"][1], 0.0);
  // The .bin's positions and tangents, as a loader reads them.
  const std::vector<uint8_t> buffer = ReadFileBytes(gltf_path.parent_path() / gltf["buffers"][0]["uri"].get<std::string>());
  EXPECT_EQ(buffer.size(), gltf["buffers"][0]["byteLength"].get<size_t>());
  const auto floats_of = [&](const std::string& attribute) {
    const nlohmann::json& accessor = gltf["accessors"][attributes[attribute].get<int>()];
    const nlohmann::json& view = gltf["bufferViews"][accessor["bufferView"].get<int>()];
    std::vector<float> values(view["byteLength"].get<size_t>() / sizeof(float));
    std::memcpy(values.data(), buffer.data() + view["byteOffset"].get<size_t>(), values.size() * sizeof(float));
    return values;
  };
  const std::vector<float> positions = floats_of("POSITION"), uvs = floats_of("TEXCOORD_0");
  const std::vector<float> tangents = floats_of("TANGENT"), normals = floats_of("NORMAL");
  ASSERT_EQ(positions.size(), 12u);
  for (int v = 0; v < 4; ++v) {
    SCOPED_TRACE(v);
    // u runs with +X, v (down the image) with +Z; normal +Y, tangent +X, w = +1.
    EXPECT_NEAR(positions[3 * v + 0], (uvs[2 * v + 0] - 0.5) * width_m, 1e-7);
    EXPECT_NEAR(positions[3 * v + 2], (uvs[2 * v + 1] - 0.5) * height_m, 1e-7);
    EXPECT_EQ(normals[3 * v + 1], 1.0f);
    EXPECT_EQ(tangents[4 * v + 0], 1.0f);
    EXPECT_EQ(tangents[4 * v + 3], 1.0f);
  }
}

TEST_F(EnginePresetExportTest, DisplacedMeshFollowsTheHeightMapWithinItsBudget) {
  const nlohmann::json gltf = ReadJsonFile(FileOf("gltf-displaced", "gltf"));
  ASSERT_EQ(gltf["meshes"].size(), 2u);
  ASSERT_EQ(gltf["scenes"][0]["nodes"].size(), 2u);
  EXPECT_FALSE(gltf["materials"][1].contains("normalTexture")) << "the grid carries the relief itself";
  EXPECT_TRUE(gltf["materials"][1]["pbrMetallicRoughness"].contains("metallicRoughnessTexture"));
  const nlohmann::json& attributes = gltf["meshes"][1]["primitives"][0]["attributes"];
  const nlohmann::json& position = gltf["accessors"][attributes["POSITION"].get<int>()];
  EXPECT_LE(position["count"].get<int>(), 5000);
  EXPECT_GE(position["count"].get<int>(), 2500) << "the coarsest step that fits, not coarser";
  // Heights in metres: within the height map's range, and spanning most of it
  // (the box mean over a grid step smooths the extremes).
  const ExportSummary& summary = Of("gltf-displaced");
  const double low = position["min"][1].get<double>() * 1000, high = position["max"][1].get<double>() * 1000;
  EXPECT_GE(low, summary.height_min_mm - 1e-4);
  EXPECT_LE(high, summary.height_max_mm + 1e-4);
  EXPECT_GT(high - low, 0.5 * (summary.height_max_mm - summary.height_min_mm));
  const double width_m = 400 * summary.mm_per_pixel / 1000;
  EXPECT_NEAR(position["min"][0].get<double>(), 1.1 * width_m - width_m / 2, 1e-6) << "beside the flat tile";
}

TEST_F(EnginePresetExportTest, TileIsWrittenInTheEngineLayoutToo) {
  TemporaryFolder local;
  ExportOptions options;
  options.preset = ExportOptions::Preset::kUnityHdrp;
  options.tileable = true;
  options.tile.tile_width = 128;
  options.output_root = local / "exports";
  ExportController controller(*result_dir_, options);
  controller.Run();
  const ExportSummary& summary = controller.summary();
  ASSERT_TRUE(summary.tile.has_value());
  EXPECT_EQ(summary.files.at("tile_mask_map"), "test_twill/test_twill_Tile_MaskMap.png");
  EXPECT_EQ(summary.files.at("tile_normal"), "test_twill/test_twill_Tile_Normal.png");
  const ImageU16 tile_mask = ReadImageU16(summary.export_dir / summary.files.at("tile_mask_map"));
  EXPECT_EQ(tile_mask.width(), 128);
  EXPECT_EQ(tile_mask.channels(), 4);
  EXPECT_EQ(tile_mask(64, 64, 2), 65535) << "detail mask";
}

TEST(EnginePresetOptionsTest, DisplacedMeshOptionsAreCheckedAndNamed) {
  ExportOptions options;
  options.gltf_displaced_mesh = true;
  try {
    options.Check();
    FAIL() << "a displaced mesh without the gltf preset";
  } catch (const std::invalid_argument& error) {
    EXPECT_THAT(error.what(), HasSubstr("ExportOptions.gltf_displaced_mesh"));
    EXPECT_THAT(error.what(), HasSubstr("needs preset gltf (the preset is png16)"));
  }
  options.preset = ExportOptions::Preset::kGltf;
  EXPECT_NO_THROW(options.Check());
  options.gltf_mesh_max_vertices = 70000;
  try {
    options.Check();
    FAIL() << "more vertices than 16-bit indices address";
  } catch (const std::invalid_argument& error) {
    EXPECT_THAT(error.what(), HasSubstr("gltf_mesh_max_vertices = 70000 must be in [4, 65536]"));
  }
  EXPECT_EQ(ExportPresetFromName("unity-hdrp"), ExportOptions::Preset::kUnityHdrp);
  EXPECT_TRUE(IsEnginePreset(ExportOptions::Preset::kGltf));
  EXPECT_FALSE(IsEnginePreset(ExportOptions::Preset::kTiff16));
}

// Node and the pinned npm packages of tests/web (scripts/test.sh installs them).
std::string MissingForValidator() {
  if (RunShell("command -v node").exit_code != 0) return "node is not installed (scripts/install-deps.sh installs it)";
  if (!fs::exists(fs::path(SCANBENCH_SOURCE_DIR) / "tests/web/node_modules/gltf-validator/package.json")) {
    return "tests/web/node_modules is missing (run: cd tests/web && npm ci; scripts/test.sh does)";
  }
  return "";
}

CommandResult Validate(const fs::path& gltf) {
  return RunShell("node " + Quoted(fs::path(SCANBENCH_SOURCE_DIR) / "tests/web/validate_gltf.js") + " " +
                  Quoted(gltf));
}

TEST_F(EnginePresetExportTest, GltfPassesTheKhronosValidator) {
  const std::string missing = MissingForValidator();
  if (!missing.empty()) GTEST_SKIP() << "glTF-Validator not run: " << missing;
  for (const std::string preset : {"gltf", "gltf-displaced"}) {
    SCOPED_TRACE(preset);
    const CommandResult result = Validate(FileOf(preset, "gltf"));
    ASSERT_EQ(result.exit_code, 0) << result.output;
    const nlohmann::json report = nlohmann::json::parse(result.output);
    EXPECT_EQ(report["numErrors"], 0) << result.output;
    EXPECT_EQ(report["numWarnings"], 0) << result.output;
    std::cout << preset << ": glTF-Validator " << report["validator"].get<std::string>() << ": "
              << report["numErrors"] << " errors, " << report["numWarnings"] << " warnings, " << report["numInfos"]
              << " infos, " << report["numHints"] << " hints\n";
  }

  // The validator does look: without its buffer the same tile fails.
  TemporaryFolder broken;
  fs::copy(FileOf("gltf", "gltf").parent_path(), broken / "tile", fs::copy_options::recursive);
  fs::remove(broken / "tile" / "test_twill.bin");
  const CommandResult failed = Validate(broken / "tile" / "test_twill.gltf");
  EXPECT_EQ(failed.exit_code, 1) << failed.output;
  EXPECT_GT(nlohmann::json::parse(failed.output)["numErrors"].get<int>(), 0);
}

// --- MaterialX ------------------------------------------------------------------

struct XmlElement {
  std::string tag;
  std::map<std::string, std::string> attributes;
  std::vector<std::unique_ptr<XmlElement>> children;
  const std::string& Attribute(const std::string& name) const {
    static const std::string kNone;
    const auto found = attributes.find(name);
    return found == attributes.end() ? kNone : found->second;
  }
};

// Parses with expat; "" on success, else expat's message and line.
std::string ParseXml(const std::string& text, XmlElement* root) {
  struct State {
    XmlElement* root;
    std::vector<XmlElement*> open;
  } state{root, {}};
  XML_Parser parser = XML_ParserCreate(nullptr);
  XML_SetUserData(parser, &state);
  XML_SetElementHandler(
      parser,
      [](void* data, const XML_Char* tag, const XML_Char** attributes) {
        auto* s = static_cast<State*>(data);
        XmlElement* element = s->open.empty() ? s->root : s->open.back()->children.emplace_back(new XmlElement).get();
        element->tag = tag;
        for (int i = 0; attributes[i] != nullptr; i += 2) element->attributes[attributes[i]] = attributes[i + 1];
        s->open.push_back(element);
      },
      [](void* data, const XML_Char*) { static_cast<State*>(data)->open.pop_back(); });
  std::string error;
  if (XML_Parse(parser, text.data(), static_cast<int>(text.size()), 1) == XML_STATUS_ERROR) {
    error = std::string(XML_ErrorString(XML_GetErrorCode(parser))) + " at line " +
            std::to_string(XML_GetCurrentLineNumber(parser));
  }
  XML_ParserFree(parser);
  return error;
}

// The signatures of the standard-library nodes the export may use: node ->
// output types it has, and input -> allowed types. From MaterialX's
// libraries/stdlib/stdlib_defs.mtlx, pbrlib/pbrlib_defs.mtlx and
// bxdf/standard_surface.mtlx (versions 1.38 and 1.39 alike for these;
// ASWF, Apache-2.0); only the inputs used here are listed.
struct NodeSignature {
  std::set<std::string> types;
  std::map<std::string, std::set<std::string>> inputs;
};
const std::map<std::string, NodeSignature>& StandardNodes() {
  static const std::map<std::string, NodeSignature> kNodes = {
      {"image", {{"float", "color3", "vector3", "vector4"}, {{"file", {"filename"}}}}},
      {"normalmap", {{"vector3"}, {{"in", {"vector3"}}, {"scale", {"float"}}}}},
      {"multiply", {{"vector3"}, {{"in1", {"vector3"}}, {"in2", {"vector3"}}}}},
      {"add", {{"vector3"}, {{"in1", {"vector3"}}, {"in2", {"vector3"}}}}},
      {"extract", {{"float"}, {{"in", {"vector3", "vector4"}}, {"index", {"integer"}}}}},
      {"sqrt", {{"float"}, {{"in", {"float"}}}}},
      {"subtract", {{"float"}, {{"in1", {"float"}}, {"in2", {"float"}}}}},
      {"standard_surface",
       {{"surfaceshader"},
        {{"base", {"float"}}, {"base_color", {"color3"}}, {"metalness", {"float"}},
         {"specular_roughness", {"float"}}, {"normal", {"vector3"}}}}},
      {"displacement", {{"displacementshader"}, {{"displacement", {"float"}}, {"scale", {"float"}}}}},
      {"surfacematerial",
       {{"material"}, {{"surfaceshader", {"surfaceshader"}}, {"displacementshader", {"displacementshader"}}}}},
  };
  return kNodes;
}

// Number of components a value of `type` has (for value="..." checks).
int Components(const std::string& type) {
  return type == "vector3" || type == "color3" ? 3 : type == "vector4" ? 4 : type == "float" || type == "integer" ? 1 : 0;
}

// Everything checkable without the MaterialX library; returns the problems.
std::vector<std::string> CheckMaterialX(const fs::path& mtlx, const std::string& expected_basecolor_space) {
  std::vector<std::string> problems;
  XmlElement root;
  const std::string parse_error = ParseXml(ReadText(mtlx), &root);
  if (!parse_error.empty()) return {"not XML: " + parse_error};
  if (root.tag != "materialx") problems.push_back("root is <" + root.tag + ">");
  if (!std::regex_match(root.Attribute("version"), std::regex("1\\.(3[89]|[4-9][0-9])"))) {
    problems.push_back("version '" + root.Attribute("version") + "' is not 1.38 or later");
  }
  const std::regex kName("[A-Za-z_][A-Za-z0-9_]*");
  // Top-level elements and node graphs: name -> element.
  std::map<std::string, const XmlElement*> top;
  for (const auto& child : root.children) {
    if (!std::regex_match(child->Attribute("name"), kName)) problems.push_back("bad name '" + child->Attribute("name") + "'");
    if (!top.emplace(child->Attribute("name"), child.get()).second) problems.push_back("duplicate " + child->Attribute("name"));
  }
  int colorspaces = 0, materials = 0;
  const auto check_node = [&](const XmlElement& node, const std::map<std::string, const XmlElement*>& scope) {
    const auto signature = StandardNodes().find(node.tag);
    if (signature == StandardNodes().end()) {
      problems.push_back("<" + node.tag + "> is not a node the export may use");
      return;
    }
    const std::string& type = node.Attribute("type");
    if (!signature->second.types.count(type)) problems.push_back(node.tag + " of type '" + type + "'");
    materials += node.tag == "surfacematerial";
    for (const auto& input : node.children) {
      const std::string where = node.Attribute("name") + "." + input->Attribute("name");
      if (input->tag != "input") {
        problems.push_back(where + ": <" + input->tag + "> inside a node");
        continue;
      }
      const auto allowed = signature->second.inputs.find(input->Attribute("name"));
      if (allowed == signature->second.inputs.end()) {
        problems.push_back(where + ": no such input of " + node.tag);
        continue;
      }
      const std::string& input_type = input->Attribute("type");
      if (!allowed->second.count(input_type)) problems.push_back(where + ": type '" + input_type + "'");
      if (!input->Attribute("colorspace").empty()) {
        ++colorspaces;
        if (!(node.tag == "image" && type == "color3" && input->Attribute("colorspace") == expected_basecolor_space)) {
          problems.push_back(where + ": colorspace '" + input->Attribute("colorspace") + "' on a " + type + " image");
        }
      }
      if (input_type == "filename" && !fs::is_regular_file(mtlx.parent_path() / input->Attribute("value"))) {
        problems.push_back(where + ": file '" + input->Attribute("value") + "' does not exist");
      }
      if (input->attributes.count("nodename")) {
        const auto source = scope.find(input->Attribute("nodename"));
        if (source == scope.end()) {
          problems.push_back(where + ": no node '" + input->Attribute("nodename") + "'");
        } else if (source->second->Attribute("type") != input_type) {
          problems.push_back(where + ": connected to a " + source->second->Attribute("type"));
        }
      } else if (input->attributes.count("nodegraph")) {
        const auto graph = top.find(input->Attribute("nodegraph"));
        bool found = false;
        if (graph != top.end()) {
          for (const auto& output : graph->second->children) {
            found |= output->tag == "output" && output->Attribute("name") == input->Attribute("output") &&
                     output->Attribute("type") == input_type;
          }
        }
        if (!found) problems.push_back(where + ": no " + input_type + " output '" + input->Attribute("output") + "'");
      } else if (input_type != "filename") {
        std::istringstream values(std::regex_replace(input->Attribute("value"), std::regex(","), " "));
        int count = 0;
        for (double value; values >> value;) ++count;
        if (count != Components(input_type)) problems.push_back(where + ": value '" + input->Attribute("value") + "'");
      }
    }
  };
  for (const auto& [name, element] : top) {
    if (element->tag == "nodegraph") {
      std::map<std::string, const XmlElement*> scope;
      for (const auto& node : element->children) {
        if (!scope.emplace(node->Attribute("name"), node.get()).second) problems.push_back("duplicate " + node->Attribute("name"));
      }
      for (const auto& node : element->children) {
        if (node->tag == "output") {
          const auto source = scope.find(node->Attribute("nodename"));
          if (source == scope.end() || source->second->Attribute("type") != node->Attribute("type")) {
            problems.push_back("output " + node->Attribute("name") + " of a missing or mistyped node");
          }
        } else {
          check_node(*node, scope);
        }
      }
    } else {
      check_node(*element, top);
    }
  }
  if (colorspaces != 1) problems.push_back(std::to_string(colorspaces) + " colorspace attributes, 1 expected (base colour)");
  if (materials != 1) problems.push_back(std::to_string(materials) + " surfacematerials");
  return problems;
}

TEST(MaterialXCheckTest, CatchesWhatItClaimsToCheck) {
  TemporaryFolder folder;
  WriteFileAtomic(folder / "a.png", std::string("x"), OverwritePolicy::kRefuse);
  const std::string good =
      "<?xml version=\"1.0\"?><materialx version=\"1.38\"><nodegraph name=\"NG\">"
      "<image name=\"i\" type=\"color3\"><input name=\"file\" type=\"filename\" value=\"a.png\" colorspace=\"srgb_texture\"/></image>"
      "<output name=\"o\" type=\"color3\" nodename=\"i\"/></nodegraph>"
      "<standard_surface name=\"S\" type=\"surfaceshader\"><input name=\"base_color\" type=\"color3\" nodegraph=\"NG\" output=\"o\"/></standard_surface>"
      "<surfacematerial name=\"M\" type=\"material\"><input name=\"surfaceshader\" type=\"surfaceshader\" nodename=\"S\"/></surfacematerial>"
      "</materialx>";
  WriteFileAtomic(folder / "good.mtlx", good, OverwritePolicy::kRefuse);
  EXPECT_THAT(CheckMaterialX(folder / "good.mtlx", "srgb_texture"), ::testing::IsEmpty());
  for (const auto& [from, to, problem] :
       {std::tuple{"a.png", "b.png", "does not exist"}, std::tuple{"1.38", "1.37", "version"},
        std::tuple{"base_color\" type=\"color3\"", "base_color\" type=\"float\"", "type 'float'"},
        std::tuple{"nodename=\"S\"", "nodename=\"T\"", "no node 'T'"},
        std::tuple{"standard_surface", "standard_surfacex", "not a node"},
        std::tuple{"srgb_texture", "lin_rec709", "colorspace 'lin_rec709'"},
        std::tuple{"</materialx>", "</materialy>", "not XML"}}) {
    SCOPED_TRACE(problem);
    std::string bad = good;
    for (size_t at = bad.find(from); at != std::string::npos; at = bad.find(from, at + std::strlen(to))) {
      bad.replace(at, std::strlen(from), to);
    }
    const fs::path path = folder / (std::to_string(std::hash<std::string>()(bad)) + ".mtlx");
    WriteFileAtomic(path, bad, OverwritePolicy::kRefuse);
    const std::vector<std::string> problems = CheckMaterialX(path, "srgb_texture");
    ASSERT_FALSE(problems.empty());
    EXPECT_THAT(problems.front() + (problems.size() > 1 ? problems[1] : ""), HasSubstr(problem));
  }
}

TEST_F(EnginePresetExportTest, MaterialXOfEveryPresetUsesStandardNodesAndItsOwnFiles) {
  for (const std::string preset : {"png16", "exr", "unreal", "unity-hdrp", "gltf"}) {
    SCOPED_TRACE(preset);
    const fs::path mtlx = FileOf(preset, "materialx");
    EXPECT_EQ(mtlx.filename(), "test_twill.mtlx");
    EXPECT_THAT(CheckMaterialX(mtlx, preset == "exr" ? "lin_rec709" : "srgb_texture"), ::testing::IsEmpty());
    const std::string text = ReadText(mtlx);
    // Each preset's roughness reaches standard_surface as perceptual roughness.
    const std::string roughness_node = preset == "unity-hdrp" ? "<subtract" : preset == "png16" || preset == "exr" ? "<sqrt" : "";
    if (!roughness_node.empty()) {
      EXPECT_THAT(text, HasSubstr(roughness_node + " name=\"perceptual_roughness\""));
    }
    EXPECT_EQ(text.find("normal_flip_green") != std::string::npos, preset == "unreal") << "DirectX normals flipped back";
    EXPECT_THAT(text, HasSubstr("value=\"" + fs::path(Of(preset).files.at("height")).filename().string() + "\""));
    EXPECT_THAT(text, HasSubstr("<input name=\"scale\" type=\"float\" value=\"0.001\" />")) << "mm -> metres";
  }
}

}  // namespace
}  // namespace scanbench
