#include "app/controllers/engine_presets.h"

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
  CheckOneChannelPair(occlusion, ggx_alpha);
  ImageF packed(occlusion.width(), occlusion.height(), 3, 0.0f);
  for (size_t i = 0; i < packed.num_pixels(); ++i) {
    packed.data()[3 * i + 0] = occlusion.data()[i];
    packed.data()[3 * i + 1] = Perceptual(ggx_alpha.data()[i]);
  }
  return packed;
}

ImageF PackHdrpMaskMap(const ImageF& occlusion, const ImageF& ggx_alpha) {
  CheckOneChannelPair(occlusion, ggx_alpha);
  ImageF packed(occlusion.width(), occlusion.height(), 4, 0.0f);
  for (size_t i = 0; i < packed.num_pixels(); ++i) {
    packed.data()[4 * i + 1] = occlusion.data()[i];
    packed.data()[4 * i + 2] = 1.0f;
    packed.data()[4 * i + 3] = 1.0f - Perceptual(ggx_alpha.data()[i]);
  }
  return packed;
}

}  // namespace scanbench
