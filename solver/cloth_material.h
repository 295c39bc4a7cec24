// The cloth material of a scan in the engines' own parameters (issue #34):
// per pixel a diffuse base colour, a Charlie sheen (colour and roughness) and
// a GGX specular term (white F0 and roughness), fitted at given normals (the
// solve's) to the samples of every light.
//
// The model is glTF 2.0's metallic-roughness material with metallic 0,
// KHR_materials_sheen and KHR_materials_specular (white specular colour), in
// the solver's units (one intensity-divided sample: a Lambertian albedo rho
// reads rho n.l), per colour channel:
//   b = s [ (1 - F) base (n.l) + F pi D_ggx V_ggx (n.l) ] + sheen pi D_charlie V_sheen (n.l)
//   F = F0 + (1 - F0) (1 - v.h)^5 where the pixel has a specular term, else 0
//   s = min(1 - max(sheen) E(n.v), 1 - max(sheen) E(n.l))   (KHR_materials_sheen's albedo scaling)
// with the lobes of solver/engine_shading.h. What an engine renders from the
// exported maps is what the fit was scored on.
//
// How it is fitted (docs/solver.md, "Cloth material"): the image is cut into
// square blocks of about a thread; the roughnesses and which terms a block
// has are shared by its pixels (the spatial regularisation: a thread is one
// material), chosen on an even spread of its pixels by BIC over a grid of
// roughnesses, and kept only if the samples held out one at a time are
// predicted better with the term than without; then every pixel's colours and F0 are a linear least-squares
// fit under the block's choice, alternated with the Fresnel and albedo
// scaling weights they set. A term the block's samples do not support is
// not reported (a Lambertian sample gets none).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "core/progress.h"
#include "core/summary.h"
#include "solver/photometric_solver.h"

namespace scanbench {

struct ClothMaterial {
  Eigen::Vector3d base_color = Eigen::Vector3d::Zero();   // glTF baseColor, linear, [0, 1]
  Eigen::Vector3d sheen_color = Eigen::Vector3d::Zero();  // KHR sheenColorFactor, linear, [0, 1]; 0 = no sheen
  double sheen_roughness = 0.5;                           // KHR sheenRoughnessFactor, [0.05, 1]
  double specular_f0 = 0;                                 // white F0, [0, 1]; 0 = no specular term
  double specular_roughness = 0.5;                        // glTF roughness (GGX alpha = its square), [0.05, 1]
};

// b of each colour channel for unit normal n, light l and view v; 0 when l or
// v is below n's horizon. Never NaN.
Eigen::Vector3d ClothMaterialValue(const ClothMaterial& material, const Eigen::Vector3d& n,
                                   const Eigen::Vector3d& l, const Eigen::Vector3d& v);

// Bits of ClothMaterialMaps::terms.
enum ClothMaterialTerm : uint8_t {
  kMaterialFitted = 1,    // the pixel has a material (else too few lit samples or not asked for)
  kMaterialSheen = 2,     // with a sheen
  kMaterialSpecular = 4,  // with a specular term
};

struct ClothMaterialFitOptions {
  // Side of the square blocks whose pixels share roughnesses and terms, px,
  // in [2, 256]: about a thread of the sample.
  int block_size = 16;
  // Pixels of a block its roughnesses and terms are chosen on (an even spread), in [1, 65536].
  int max_decision_pixels = 32;
  // Lit, valid samples a pixel needs to be fitted, in [4, 10000] (a block
  // with a sheen fits 3 colours and 3 sheen colours from 3 per sample).
  int min_samples = 5;
  // The grids of roughnesses a block chooses from, each value in [0.05, 1], not empty.
  std::vector<double> sheen_roughnesses = {0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0};
  std::vector<double> specular_roughnesses = {0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.5, 0.6, 0.7};
  bool fit_sheen = true;     // false: no block gets a sheen
  bool fit_specular = true;  // false: no block gets a specular term (both false: the Lambertian fit)
  // A term is kept only when it lowers the block's BIC by more than this, >= 0.
  double bic_margin = 10;
  // ... and only when it also predicts the block's samples held out one at a
  // time (leave one out, on the decision pixels) better than the diffuse fit
  // by at least this share of its squared error, in [0, 1]; 1 = no such test.
  double min_held_out_gain = 0.05;
  // Alternations of the linear fit with the Fresnel and albedo-scaling
  // weights its last colours set, in [1, 10].
  int iterations = 2;
  // A light left out of the fit (the relighting check), -1 = none; must be a light of the input.
  int held_out_light = -1;
  int num_threads = 0;  // 0 = every core

  void Check() const;
};

struct ClothMaterialMaps {
  ImageF base_color;          // 3 channels, linear; 0 where not fitted
  ImageF sheen_color;         // 3 channels, linear; 0 without a sheen
  ImageF sheen_roughness;     // 1 channel; 0 without a sheen
  ImageF specular;            // 2 channels: white F0 and glTF roughness; 0 without a specular term
  ImageU8 terms;              // ClothMaterialTerm bits
  // 4 channels, standard errors: the sheen colour's (mean over the channels),
  // the sheen roughness's, F0's, the specular roughness's; 0 where the term
  // is absent. The colours' and F0's from the linear fit's covariance, the
  // roughnesses' half the span of the grid values within 2 of the block's best BIC.
  ImageF confidence;
};

// The material of pixel (x, y) of `maps` (zero where not fitted).
ClothMaterial MaterialAt(const ClothMaterialMaps& maps, int x, int y);

struct ClothMaterialFitSummary : AlgorithmSummary {
  size_t pixels_fitted = 0;
  size_t pixels_sheen = 0;
  size_t pixels_specular = 0;
  size_t pixels_too_few_samples = 0;  // asked for, not fitted
  size_t blocks = 0;                  // blocks with a pixel to fit
  size_t blocks_sheen = 0;
  size_t blocks_specular = 0;
  double seconds = 0;
  std::string BriefReport() const;
};

// Fits the material at `normals` (3 channels in the light field's frame, e.g.
// PhotometricSolution::normal_in_table) on the non-zero pixels of `pixels`
// (1 channel, the input's size), from input.images and the light field
// (input.sample_valid marks unusable samples; input.region is not used).
// Throws std::invalid_argument on bad options or shapes; a cancel through
// `progress` returns kCancelled with the blocks not reached unfitted.
ClothMaterialFitSummary FitClothMaterial(const ClothMaterialFitOptions& options, const PhotometricSolverInput& input,
                                         const ImageF& normals, const ImageU8& pixels, ClothMaterialMaps* maps,
                                         const ProgressCallback& progress = {});

}  // namespace scanbench
