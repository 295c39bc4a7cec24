// Spatial coherence for the specular lobe (issue #13): pixels of one thread
// share a BRDF, so their lobe is fitted once from all of them.
//
// With 10 lights a per-pixel anisotropic lobe (normal, albedo, F0, two
// alphas, tangent azimuth: 7 unknowns) is under-determined, and an isotropic
// one fitted to an anisotropic highlight (satin) bends the normal to explain
// it. RefineCoherentLobe runs after the per-pixel passes. It cuts the image
// into square blocks; a block with at least min_pixels pixels of lobe support
// (SpecularStatus::kEstimated) has its solved pixels split into groups of
// similar albedo chromaticity (warp and weft in one block; a third, e.g. where
// they mix, only where every group can be fitted: max_albedo_groups), and
// each group with enough lobe pixels of its own alternates
//   1. one anisotropic GGX lobe (F0, alpha_t, alpha_b, tangent azimuth) for
//      the whole group, the normals held (each pixel's diffuse amplitude
//      re-solved linearly at every trial; a grid over the shape, then a
//      pattern search), and
//   2. each pixel's normal and diffuse albedo re-solved under that lobe
//      (Levenberg-Marquardt, the highlight samples down-weighted:
//      highlight_weight)
// a few times, with Tukey weights on every residual. The first alternation
// is run with Lambert's diffuse (n . l) and with the diffuse light that
// crosses a Schlick-Fresnel interface on the way in, (n . l)(1 - (1 - n .
// l)^5) (fresnel_diffuse), and the latter kept only where it lowers the fit
// pixels' residual on their common samples by 15 %; then every pixel of the
// group takes the group's result. In a Lambertian group a pixel takes the
// shared-lobe result only where that lowers its residual against its own
// per-pixel result re-evaluated on the same weighted samples (both floored
// at the noise; a tie against a Lambertian result goes to the shared lobe);
// else it is left as it was. Blocks without lobe pixels cost one scan.
// Luminance model per sample (intensity divided, as FitDiffuseLobe's):
//   b_k = rho_d (n . l_k) + rho_s / (4 (n . v) alpha_t alpha_b Q^2),
//   Q = (h . t / alpha_t)^2 + (h . b / alpha_b)^2 + (h . n)^2,
// times the height-correlated Smith masking-shadowing G(l, v) of the same
// anisotropic GGX (Heitz 2014), i.e. (n . l) (rho_d + rho_s pi D G / (4 (n . l)
// (n . v))), h the half vector, t the tangent at the fitted azimuth projected
// into n's tangent plane, b = n x t; a constant Fresnel (rho_s = F0).
// The specular map stores rho_s and the geometric mean sqrt(alpha_t
// alpha_b) (the isotropic alpha of equal lobe solid angle): the map format
// is unchanged; the tangent and the anisotropy are not stored.
#pragma once

#include <cstddef>
#include <string>

#include <Eigen/Core>

#include "core/progress.h"
#include "core/summary.h"
#include "solver/photometric_solver.h"

namespace scanbench {

struct CoherentLobeOptions {
  // Side of the square blocks whose pixels may share a lobe, pixels, in [4, 256].
  int block_size = 32;
  // Fewest supported pixels of one albedo group to fit its shared lobe, in [4, 65536].
  int min_pixels = 12;
  // Pixels of a group the lobe shape is fitted on (evenly spread), in [4, 65536];
  // every pixel of the group is re-solved.
  int max_fit_pixels = 64;
  // Alternations of the shared-lobe fit and the per-pixel re-solve, in [1, 20].
  int iterations = 3;
  // Bounds of both GGX alphas, 0 < min_alpha < max_alpha <= 1.
  double min_alpha = 0.02;
  double max_alpha = 0.6;
  // A block's supported pixels are split into groups when the centres of
  // their albedo chromaticity clusters (r, g of rgb / sum) are further apart
  // than this (a further centre only beyond it from those chosen), >= 0 (a
  // large value never splits).
  double albedo_split = 0.03;
  // At most this many albedo groups per block (k-means on the albedo
  // chromaticity), in [1, 8]; more than 2 only where every group can be
  // fitted on its own (min_pixels pixels, half of them with a per-pixel
  // lobe), else 2 (satin 0.829 -> 0.781 deg with 3; docs/solver.md).
  int max_albedo_groups = 3;
  // The pass runs only on solves with at most this many lights, in [3, 1000]:
  // with many lights the per-pixel lobe is determined on its own (DiLiGenT's
  // 96: ball 1.803 -> 1.792 deg, bear 4.379 -> 4.318, for 2.2x bear's solve
  // CPU time, beyond the 2 s budget), the pass is for the rig's ten.
  int max_lights = 24;
  // In the per-pixel normal re-solve under the shared lobe each sample's
  // weight is divided by 1 + highlight_weight x its lobe fraction (rho_s S /
  // the model): the highlight samples, which the shared shape fits only
  // roughly, steer the normal less; the shape fit, the model selection and
  // the albedo keep the plain Tukey weights. >= 0 (0 = off; satin 1.394 deg,
  // 10: 1.114, 30: 1.072, 100: 1.076; docs/solver.md).
  double highlight_weight = 30;
  // Each pixel keeps its own lobe amplitude (rho_s) under the shared shape;
  // else the group shares one F0.
  bool per_pixel_amplitude = false;
  // Each group also tries the Fresnel-transmitted diffuse term (n . l) (1 -
  // (1 - n . l)^5) in place of Lambert's and keeps it where it leaves at most
  // 0.85 of the Lambertian fit's residual (then every pixel of the group
  // takes the group's result); false: Lambert's only (a third less time;
  // docs/solver.md).
  bool fresnel_diffuse = true;
  // Worker threads; 0 = all hardware threads, in [0, 256].
  int num_threads = 0;

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

struct CoherentLobeSummary : AlgorithmSummary {
  bool skipped_lights = false;  // more lights than max_lights: nothing done
  size_t pixels_supported = 0;  // solved pixels with a per-pixel lobe (the candidates)
  size_t groups_fitted = 0;     // block albedo groups a shared lobe was fitted to
  size_t groups_fresnel = 0;    // of those, with the Fresnel-transmitted diffuse term
  size_t pixels_refined = 0;    // pixels that took the shared-lobe result
  size_t pixels_kept = 0;       // candidates in fitted groups that kept their per-pixel result (BIC)
  size_t pixels_bayer = 0;      // refined pixels re-solved from their raw samples (input.lobe_mosaics)
  double mean_anisotropy = 0;   // mean alpha_b / alpha_t (>= 1) over the fitted groups
  double seconds = 0;
  std::string BriefReport() const;
};

// Refines `solution` (a per-pixel solve of `input` with `solver_options`, its
// specular maps filled) in place; pixels without lobe support are not
// touched. Empty specular maps: nothing to refine (success, no change). The
// samples are taken as the solver takes them (solver_options' luminance
// weights, shadow level, light intensity floor, sample masks; its
// robust_min_scale and robust_loss_width for the noise floor and the Tukey
// width). Throws std::invalid_argument on inputs that do not fit the
// solution; a cancelled run returns kCancelled with the blocks done so far
// refined and the rest as they were. With input.lobe_mosaics (and
// input.lobe_bayer) every pixel that takes the shared lobe is re-solved once
// more from its own raw CFA samples under the group's final lobe (shape, F0,
// diffuse term; its demosaiced normal the start, the highlight down-weighted
// as there): *input.lobe_bayer is made the light field's size with normal,
// status (kSolved only there, else kOutsideRegion), residual and lights_used,
// what BlendBayerNormals takes on lobe pixels. With fewer than min_pixels
// lobe pixels in all (nothing to fit) it is left empty.
CoherentLobeSummary RefineCoherentLobe(const CoherentLobeOptions& options,
                                       const PhotometricSolverOptions& solver_options,
                                       const PhotometricSolverInput& input, PhotometricSolution* solution,
                                       const ProgressCallback& progress = {});

// The lobe's shape term S (b = rho_d (n . l) + rho_s S) for unit normal n,
// unit light and view directions; `tangent_azimuth` (radians, table frame,
// about z) gives t; alpha_t along t, alpha_b across. `masking`: times the
// height-correlated Smith masking-shadowing G (what the shared lobe fits);
// without it and with alpha_t == alpha_b it is FitDiffuseLobe's isotropic
// term. Never NaN for unit inputs.
double AnisotropicLobeShape(const Eigen::Vector3d& n, const Eigen::Vector3d& light, const Eigen::Vector3d& view,
                            double tangent_azimuth, double alpha_t, double alpha_b, bool masking = true);

}  // namespace scanbench
