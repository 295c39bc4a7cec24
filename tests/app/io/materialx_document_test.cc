// The MaterialX document on its own: options checked and named, element
// names made valid, and each roughness encoding converted to perceptual
// roughness (the export test parses real exports' documents as XML).
#include "app/io/materialx_document.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace scanbench {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

MaterialXMaterialOptions Options() {
  MaterialXMaterialOptions options;
  options.name = "3-ply.twill";
  options.basecolor_file = "a&b.png";
  options.normal_file = "n.png";
  options.roughness_file = "r.png";
  options.height_file = "h.exr";
  return options;
}

TEST(MaterialXDocumentTest, OptionsAreCheckedAndNamed) {
  for (const auto& [change, field] :
       std::vector<std::pair<std::function<void(MaterialXMaterialOptions&)>, std::string>>{
           {[](auto& o) { o.height_file.clear(); }, "height_file"},
           {[](auto& o) { o.basecolor_colorspace = "srgb"; }, "basecolor_colorspace"},
           {[](auto& o) { o.roughness_channel = 1; }, "roughness_channel"},
           {[](auto& o) { o.roughness_channels = 2; }, "roughness_channels"},
           {[](auto& o) { o.height_scale = 0; }, "height_scale"}}) {
    MaterialXMaterialOptions options = Options();
    change(options);
    try {
      MaterialXDocument(options);
      ADD_FAILURE() << field << " not checked";
    } catch (const std::invalid_argument& error) {
      EXPECT_THAT(error.what(), HasSubstr("MaterialXMaterialOptions." + field));
    }
  }
}

TEST(MaterialXDocumentTest, NamesAreValidAndRoughnessBecomesPerceptual) {
  MaterialXMaterialOptions options = Options();
  const std::string alpha = MaterialXDocument(options);
  EXPECT_THAT(alpha, HasSubstr("<surfacematerial name=\"M_m_3_ply_twill\""));  // no leading digit, '.' and '-'
  EXPECT_THAT(alpha, HasSubstr("value=\"a&amp;b.png\" colorspace=\"srgb_texture\""));
  EXPECT_THAT(alpha, HasSubstr("<sqrt name=\"perceptual_roughness\""));
  EXPECT_THAT(alpha, Not(HasSubstr("<extract")));
  options.roughness = MaterialXMaterialOptions::Roughness::kSmoothness;
  options.roughness_channels = 4;
  options.roughness_channel = 3;
  const std::string smoothness = MaterialXDocument(options);
  EXPECT_THAT(smoothness, HasSubstr("<image name=\"roughness_image\" type=\"vector4\">"));
  EXPECT_THAT(smoothness, HasSubstr("<input name=\"index\" type=\"integer\" value=\"3\" />"));
  EXPECT_THAT(smoothness, HasSubstr("<subtract name=\"perceptual_roughness\""));
  options.roughness = MaterialXMaterialOptions::Roughness::kPerceptual;
  options.normal_y_down = true;
  const std::string perceptual = MaterialXDocument(options);
  EXPECT_THAT(perceptual, Not(HasSubstr("perceptual_roughness")));
  EXPECT_THAT(perceptual, HasSubstr("<output name=\"specular_roughness_out\" type=\"float\" nodename=\"roughness_channel\" />"));
  EXPECT_THAT(perceptual, HasSubstr("<input name=\"in2\" type=\"vector3\" value=\"1, -1, 1\" />"));
}

}  // namespace
}  // namespace scanbench
