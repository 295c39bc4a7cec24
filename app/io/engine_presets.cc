#include "app/io/engine_presets.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace scanbench {
namespace {

void CheckOneChannelPair(const ImageF& occlusion, const ImageF& ggx_alpha) {
  if (occlusion.channels() != 1 || ggx_alpha.channels() != 1 || !occlusion.SameSize(ggx_alpha) ||
      occlusion.empty()) {
    throw std::invalid_argument("engine packing: occlusion is " + std::to_string(occlusion.width()) + "x" +
                                std::to_string(occlusion.height()) + "x" + std::to_string(occlusion.channels()) +
                                " and roughness " + std::to_string(ggx_alpha.width()) + "x" +
                                std::to_string(ggx_alpha.height()) + "x" + std::to_string(ggx_alpha.channels()) +
                                "; both must be one channel of the same, non-zero size");
  }
}

float Perceptual(float ggx_alpha) { return std::sqrt(std::clamp(ggx_alpha, 0.0f, 1.0f)); }

// A `channels` image, zero but where `set(pixel, occlusion, perceptual roughness)` writes.
template <typename SetPixel>
ImageF Pack(const ImageF& occlusion, const ImageF& ggx_alpha, int channels, SetPixel set) {
  CheckOneChannelPair(occlusion, ggx_alpha);
  ImageF packed(occlusion.width(), occlusion.height(), channels, 0.0f);
  for (size_t i = 0; i < packed.num_pixels(); ++i) {
    set(packed.data() + channels * i, occlusion.data()[i], Perceptual(ggx_alpha.data()[i]));
  }
  return packed;
}

}  // namespace

EngineTextureNames EngineTextureNamesOf(EngineTarget target, const std::string& stem) {
  switch (target) {
    case EngineTarget::kUnreal:
      return {"T_" + stem + "_BC.png", "T_" + stem + "_N.png", "T_" + stem + "_ORM.png", "T_" + stem + "_H.png"};
    case EngineTarget::kUnityHdrp:
      return {stem + "_BaseMap.png", stem + "_Normal.png", stem + "_MaskMap.png", stem + "_HeightMap.png"};
    case EngineTarget::kGltf:
      return {stem + "_baseColor.png", stem + "_normal.png", stem + "_occlusionRoughnessMetallic.png", ""};
  }
  return {};
}

bool EngineNormalIsDirectX(EngineTarget target) { return target == EngineTarget::kUnreal; }

ImageF PerceptualRoughnessFromGgxAlpha(const ImageF& ggx_alpha) {
  ImageF perceptual = ggx_alpha;
  for (size_t i = 0; i < perceptual.size(); ++i) perceptual.data()[i] = Perceptual(perceptual.data()[i]);
  return perceptual;
}

ImageF PackOcclusionRoughnessMetallic(const ImageF& occlusion, const ImageF& ggx_alpha) {
  return Pack(occlusion, ggx_alpha, 3, [](float* rgb, float ao, float perceptual) {
    rgb[0] = ao;
    rgb[1] = perceptual;
  });
}

ImageF PackHdrpMaskMap(const ImageF& occlusion, const ImageF& ggx_alpha) {
  return Pack(occlusion, ggx_alpha, 4, [](float* rgba, float ao, float perceptual) {
    rgba[1] = ao;
    rgba[2] = 1.0f;
    rgba[3] = 1.0f - perceptual;
  });
}

}  // namespace scanbench
