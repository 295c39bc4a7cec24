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
  EXPECT_EQ(gltf["materials"][0]["pbrMetallicRoughness"]["metallicFactor"], 0.0);
}

}  // namespace
}  // namespace scanbench
