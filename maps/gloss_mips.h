// Roughness mip chain that pushes normal variance into roughness, so a bumpy
// but glossy material does not turn mirror-like in the distance. Two models:
// the vMF fit of seed 000 (average normal length r, kappa = (3r - r^3) /
// (1 - r^2), alpha' = sqrt(alpha^2 + 1 / kappa)) and the GGX shortened-normal
// mapping of seed 004 (gloss <-> average normal length of the GGX NDF,
// macrosurface-area model, shortened normals averaged down the chain).
#pragma once

#include <string>
#include <vector>

#include "maps/map_summary.h"
#include "solver/image.h"

namespace scanbench {

struct GlossMipOptions {
  enum class Model { kVmf, kGgxNormalLength };
  Model model = Model::kVmf;
  double base_roughness = 0.3;   // GGX alpha of mip 0 where no roughness map is given, (0, 1]
  int max_levels = 0;            // mips including mip 0; 0 = down to 1x1, >= 0
  void Check() const;
};
const char* GlossModelName(GlossMipOptions::Model model);
// "vmf" or "ggx"; throws std::invalid_argument naming the value otherwise.
GlossMipOptions::Model GlossModelFromName(const std::string& name);

struct GlossMipLevel {
  ImageF normal_in_tangent;      // 3 channels, unit
  ImageF roughness;              // 1 channel, GGX alpha in (0, 1]
};

struct GlossMipSummary {
  MapTermination termination = MapTermination::kFailure;
  std::string message;
  std::string model;
  std::vector<double> mean_roughness;   // per level
  double seconds = 0;
};

// Each level halves the size (odd sizes round up, edge texels cover fewer
// source texels). roughness: optional 1-channel GGX alpha per pixel of mip 0.
// Gloss in the seed-004 parameterisation is available through the helpers.
std::vector<GlossMipLevel> BuildGlossMipChain(const ImageF& normal_in_tangent, const ImageF* roughness,
                                              const GlossMipOptions& options, GlossMipSummary* summary);

// Seed 004: gloss in [0, 1] <-> GGX alpha, alpha = sqrt(2 / (1 + 2^(18 * gloss))).
double GlossToGgxAlpha(double gloss);
double GgxAlphaToGloss(double alpha);
// Average normal length of the GGX NDF with this alpha (macrosurface-area
// model), in (0, 1]; and its inverse.
double GgxAlphaToNormalLength(double alpha);
double NormalLengthToGgxAlpha(double length);

}  // namespace scanbench
