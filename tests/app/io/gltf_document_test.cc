// The glTF 2.0 tile on its own: its options are checked and named, and the
// buffer holds what the accessors say (the export test runs the Khronos
// validator on a real export).
#include "app/io/gltf_document.h"

#include <cstring>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace scanbench {
namespace {

using ::testing::HasSubstr;

GltfTileOptions Options() {
  GltfTileOptions options;
  options.name = "twill";
  options.width_m = 0.2;
  options.height_m = 0.1;
  options.basecolor_uri = "b.png";
  options.normal_uri = "n.png";
  options.occlusion_roughness_metallic_uri = "orm.png";
  options.buffer_uri = "twill.bin";
  return options;
}

TEST(GltfDocumentTest, OptionsAreCheckedAndNamed) {
  GltfTileOptions options = Options();
  options.width_m = -1;
  EXPECT_THROW(
      try { BuildGltfTile(options); } catch (const std::invalid_argument& error) {
        EXPECT_THAT(error.what(), HasSubstr("GltfTileOptions.width_m"));
        throw;
      },
      std::invalid_argument);
  options = Options();
  options.normal_uri.clear();
  EXPECT_THROW(
      try { BuildGltfTile(options); } catch (const std::invalid_argument& error) {
        EXPECT_THAT(error.what(), HasSubstr("normal_uri"));
        throw;
      },
      std::invalid_argument);
}

TEST(GltfDocumentTest, AccessorsDescribeTheBuffer) {
  const GltfTileFiles files = BuildGltfTile(Options());
  const nlohmann::json gltf = nlohmann::json::parse(files.json);
  EXPECT_EQ(gltf["buffers"][0]["byteLength"], files.buffer.size());
  EXPECT_EQ(gltf["buffers"][0]["uri"], "twill.bin");
  size_t covered = 0;
  for (const auto& accessor : gltf["accessors"]) {
    const auto& view = gltf["bufferViews"][accessor["bufferView"].get<int>()];
    const size_t components = accessor["type"] == "VEC4"   ? 4
                              : accessor["type"] == "VEC3" ? 3
                              : accessor["type"] == "VEC2" ? 2
                                                           : 1;
    const size_t bytes = accessor["componentType"] == 5126 ? 4 : 2;
    EXPECT_EQ(view["byteLength"].get<size_t>(), accessor["count"].get<size_t>() * components * bytes);
    EXPECT_EQ(view["byteOffset"].get<size_t>() % bytes, 0u) << "aligned to its component";
    covered += view["byteLength"].get<size_t>();
  }
  EXPECT_EQ(covered, files.buffer.size());
  // The last view: the indices, two counter-clockwise triangles over 4 corners.
  const auto& index_view = gltf["bufferViews"].back();
  std::vector<uint16_t> indices(6);
  std::memcpy(indices.data(), files.buffer.data() + index_view["byteOffset"].get<size_t>(), 12);
  EXPECT_EQ(indices, (std::vector<uint16_t>{0, 1, 2, 0, 2, 3}));
  const auto& position = gltf["accessors"][0];
  EXPECT_FLOAT_EQ(position["max"][0].get<float>(), 0.1f);  // float, as the buffer holds it
  EXPECT_FLOAT_EQ(position["max"][2].get<float>(), 0.05f);
  EXPECT_FLOAT_EQ(position["min"][0].get<float>(), -0.1f);  // per component
  EXPECT_FLOAT_EQ(position["min"][1].get<float>(), 0.0f);
  EXPECT_FLOAT_EQ(position["min"][2].get<float>(), -0.05f);
  EXPECT_EQ(gltf["materials"][0]["pbrMetallicRoughness"]["metallicFactor"], 0.0);
}

TEST(GltfDocumentTest, DisplacedGridFitsItsBudgetAndItsNormalsFollowTheSlope) {
  EXPECT_EQ(DisplacedGridSize(1232, 816, 65536).step_px, 4);  // 308 x 204 nodes
  EXPECT_EQ(DisplacedGridSize(1232, 816, 65536).nodes_x, 308);
  EXPECT_EQ(DisplacedGridSize(65, 33, 100000).step_px, 1);
  const GltfGridSize small = DisplacedGridSize(65, 33, 200);
  EXPECT_LE(small.nodes_x * small.nodes_y, 200);
  EXPECT_GT(DisplacedGridSize(65, 33, 200).step_px, DisplacedGridSize(65, 33, 400).step_px);

  // A plane rising 0.5 height units per pixel, 1 mm pixels and mm heights:
  // slope 0.5 along +X, so the normal is (-0.5, 1, 0) / |.| away from the border.
  ImageF height(65, 33, 1);
  for (int y = 0; y < 33; ++y) {
    for (int x = 0; x < 65; ++x) height(x, y) = 0.5f * x;
  }
  GltfTileOptions options = Options();
  options.width_m = 0.065;
  options.height_m = 0.033;
  options.displaced_max_vertices = 300;
  const GltfTileFiles files = BuildGltfTile(options, &height);
  const nlohmann::json gltf = nlohmann::json::parse(files.json);
  ASSERT_EQ(gltf["meshes"].size(), 2u);
  const nlohmann::json& attributes = gltf["meshes"][1]["primitives"][0]["attributes"];
  const auto floats = [&](const char* attribute) {
    const auto& view = gltf["bufferViews"][gltf["accessors"][attributes[attribute].get<int>()]["bufferView"].get<int>()];
    std::vector<float> values(view["byteLength"].get<size_t>() / 4);
    std::memcpy(values.data(), files.buffer.data() + view["byteOffset"].get<size_t>(), values.size() * 4);
    return values;
  };
  const std::vector<float> positions = floats("POSITION"), normals = floats("NORMAL");
  const GltfGridSize size = DisplacedGridSize(65, 33, 300);
  ASSERT_EQ(positions.size(), size_t(3 * size.nodes_x * size.nodes_y));
  const double norm = std::sqrt(1.25);
  for (int j = 1; j + 1 < size.nodes_y; ++j) {
    for (int i = 2; i + 2 < size.nodes_x; ++i) {
      const size_t k = size_t(j) * size.nodes_x + i;
      EXPECT_NEAR(normals[3 * k + 0], -0.5 / norm, 1e-5) << i << "," << j;
      EXPECT_NEAR(normals[3 * k + 1], 1 / norm, 1e-5);
      EXPECT_NEAR(normals[3 * k + 2], 0, 1e-6);
      // Height: the plane at the node's pixel, in metres (x offset 1.1 widths).
      const double x_m = positions[3 * k + 0] - 1.1 * 0.065 + 0.0325;
      EXPECT_NEAR(positions[3 * k + 1], 0.5 * (x_m * 1000 - 0.5) * 0.001, 1e-7);
    }
  }
  const ImageF rgb(4, 4, 3);
  EXPECT_THROW(BuildGltfTile(options, &rgb), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
