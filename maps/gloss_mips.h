// Roughness mip chain that pushes normal variance into roughness, so a bumpy
// but glossy material does not turn mirror-like in the distance. Two models:
// the vMF fit of seed 000 (average normal length r, kappa = (3r - r^3) /
// (1 - r^2), alpha' = sqrt(alpha^2 + 1 / kappa)) and the GGX shortened-normal
// mapping of seed 004 (gloss <-> average normal length of the GGX NDF,
// macrosurface-area model, shortened normals averaged down the chain).
//
// Every texel of every level is computed from the mip-0 texels in its
// footprint with equal weights (sums and counts are carried down the chain,
// so odd sizes, where edge texels cover fewer source texels, stay exact).
// Invalid mip-0 normals (a non-finite component or length < 1e-6) and pixels
// outside the optional valid mask carry no weight; a texel without any
// weighted source is (0, 0, 1) with base_roughness.
// Other normals are normalised first. All arithmetic is in double.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "core/progress.h"
#include "core/summary.h"
#include "core/image.h"

namespace scanbench {

// Smallest GGX alpha the chain produces or accepts; smaller values are clamped
// up (gloss 1 of seed 004 is alpha 0.00276).
inline constexpr double kMinGgxAlpha = 1e-4;

struct GlossMipOptions {
  enum class Model { kVmf, kGgxNormalLength };
  Model model = Model::kVmf;
  double base_roughness = 0.3;   // GGX alpha of mip 0 where no roughness map is given, [kMinGgxAlpha, 1]
  int max_levels = 0;            // mips including mip 0; 0 = down to 1x1, >= 0
  // false: levels[0].normal_in_tangent is left empty (it is the input
  // normalised again; the export writes the input itself, so making it was
  // 192 MB of fresh pages at 16 MP for nothing). The other levels are the same.
  bool mip0_normals = true;
  void Check() const;
};
const char* GlossModelName(GlossMipOptions::Model model);
// "vmf" or "ggx"; throws std::invalid_argument naming the value otherwise.
GlossMipOptions::Model GlossModelFromName(const std::string& name);

struct GlossMipLevel {
  ImageF normal_in_tangent;      // 3 channels, unit
  ImageF roughness;              // 1 channel, GGX alpha in [kMinGgxAlpha, 1]
};

struct GlossMipSummary : AlgorithmSummary {
  std::string model;                    // GlossModelName
  std::vector<double> mean_roughness;   // per level, over texels with at least one valid source normal, GGX alpha
  size_t invalid_normals = 0;           // mip-0 normals that carried no weight (non-finite or zero)
  size_t masked_pixels = 0;             // mip-0 pixels outside the valid mask (valid normals only)
  size_t clamped_roughness = 0;         // roughness-map pixels outside [kMinGgxAlpha, 1] (clamped) or
                                        // non-finite (base_roughness used)
  double seconds = 0;
  // "Gloss mips (vmf): success, 12 levels, mean GGX alpha 0.300 at mip 0, 0.350 at the last, 0.03 s".
  std::string BriefReport() const;
};

// Each level halves the size (odd sizes round up, edge texels cover fewer
// source texels): 37x20 -> 19x10 -> 10x5 -> 5x3 -> 3x2 -> 2x1 -> 1x1.
// roughness: optional 1-channel GGX alpha per pixel of mip 0. valid:
// optional 1-channel mask, 0 = leave the pixel out of every coarser level
// (e.g. the solver's unsolved pixels, which read (0, 0, 1)); mip 0 keeps it.
// Mip 0 is the input itself (normals normalised, roughness clamped).
//  kVmf: alpha' = sqrt(mean(alpha^2) + 1 / kappa) over the footprint, kappa
//    from the length r of the mean unit normal (r = 1: 1 / kappa = 0, r = 0:
//    alpha' = 1); direction = the normalised mean.
//  kGgxNormalLength (algorithm 3 of seed 004): mean of n * GgxAlphaToNormalLength(alpha)
//    over the footprint; alpha = NormalLengthToGgxAlpha(|mean|), direction = mean / |mean|.
// Writes the levels, mip 0 first, into *levels. Throws std::invalid_argument
// (naming the image and its shape) for an empty or non-3-channel normal map,
// a roughness map or mask of another size or channel count, a null output,
// and for bad options, before any work. Termination is kFailure (levels
// still written, flat) when no normal carries weight; kCancelled (no levels)
// when `progress`, asked after each level, returns false.
// Gloss in the seed-004 parameterisation is available through the helpers.
GlossMipSummary BuildGlossMipChain(const GlossMipOptions& options, const ImageF& normal_in_tangent,
                                   const ImageF* roughness, const ImageU8* valid, std::vector<GlossMipLevel>* levels,
                                   const ProgressCallback& progress = {});

// Size of every level BuildGlossMipChain makes for a width x height mip 0
// (max_levels as in the options), as {width, height} pairs.
std::vector<std::pair<int, int>> GlossMipLevelSizes(int width, int height, int max_levels = 0);

// Seed 004 eq. 2: gloss in [0, 1] <-> GGX alpha, alpha = sqrt(2 / (1 + 2^(18 * gloss))).
// Inputs outside the domain are clamped (gloss to [0, 1], alpha to (0, 1];
// alpha below that of gloss 1, 0.00276, gives gloss 1); NaN throws std::invalid_argument.
double GlossToGgxAlpha(double gloss);
double GgxAlphaToGloss(double alpha);
// Average normal length of the GGX NDF with this alpha in the macrosurface-area
// model, E[cos theta_m] under the pdf D(m) cos(theta_m); closed form (seed 004
// eq. 26, a = sqrt(1 - alpha^2)): (a - alpha^2 atanh(a)) / a^3, a power series
// for small a. 2/3 at alpha 1, -> 1 as alpha -> 0. Alpha is clamped to [0, 1].
double GgxAlphaToNormalLength(double alpha);
// Inverse of the above (monotone): a table bracket then safeguarded regula
// falsi on the closed form, to ~1e-12 relative. Result in [kMinGgxAlpha, 1]
// (length <= 2/3 gives 1, length too close to 1 gives kMinGgxAlpha).
double NormalLengthToGgxAlpha(double length);

}  // namespace scanbench
