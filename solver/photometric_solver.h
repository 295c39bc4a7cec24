// Per-pixel Lambertian photometric stereo: (n . l) k_d i = I.
//
// Each sample is first divided by the light's intensity at the pixel, giving
// I' = N . l with N = k_d n (the scaled normal). One least-squares solve on
// luminance gives the normal; one per colour channel gives the albedo as the
// length of that channel's scaled normal.
//
// One options struct selects the method. The methods, one row each (name,
// description, light sharing, passes, kernel), are the method table in
// solver/photometric_methods.h; docs/solver.md compares them.
// The work runs in tiles on a thread pool; the inner loops run over
// structure-of-arrays spans that the compiler vectorises.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/progress.h"
#include "core/summary.h"
#include "solver/light_field.h"

namespace scanbench {

// Why a pixel has no solution. Stored per pixel in PhotometricSolution::status.
enum class PixelStatus : uint8_t {
  kSolved = 0,
  kOutsideRegion = 1,    // not asked for
  kTooFewLights = 2,     // fewer than min_lights usable samples
  kIllConditioned = 3,   // light matrix condition number above the limit
  kNoSignal = 4,         // scaled normal too short: black or unlit
  kFacingAway = 5,       // solved normal points away from the camera side
  kInvalidInput = 6,     // non-finite light value
};
inline constexpr int kNumPixelStatuses = 7;
const char* PixelStatusName(PixelStatus status);

// Which path solved a pixel. Stored per pixel in PhotometricSolution::solve_path.
enum class SolvePath : uint8_t {
  kNone = 0,                // not solved by any path (outside the region, or unsolvable)
  kSharedLights = 1,        // light field uniform over the tile: one light matrix shared
  kInterpolatedLights = 2,  // per-pixel solve, lights interpolated over the tile
  kExactLights = 3,         // per-pixel solve, lights evaluated at the pixel
  kRobust = 4,              // robust re-solve (IRLS or sparse Bayesian) gave the result
  kLearned = 5,             // the learned network's normal (solver/normal_network.h) gave the result
};
inline constexpr int kNumSolvePaths = 6;
const char* SolvePathName(SolvePath path);

// Whether a pixel's specular lobe (PhotometricSolution::specular) was
// estimated. Stored per pixel in PhotometricSolution::specular_status.
enum class SpecularStatus : uint8_t {
  kEstimated = 0,    // the samples constrain a lobe: specular holds its F0 and roughness
  kNotSolved = 1,    // the pixel itself is not solved (see status)
  kUnsupported = 2,  // solved, but no sample near the mirror direction or the lobe is within the noise
};
inline constexpr int kNumSpecularStatuses = 3;
const char* SpecularStatusName(SpecularStatus status);

struct PhotometricSolverOptions {
  // One row each in the method table (solver/photometric_methods.cc), in
  // this order.
  enum class Method {
    kAdaptive,              // default
    kJacobiSvd,             // the reference
    kNormalEquations,
    kQr,
    kUniformPseudoInverse,  // needs a uniform light field
    kRobustIrls,
    kSparseBayesian,
    kDiffuseLobe,
    kLearned,               // the network trained on the project's renders (issue #33)
  };
  enum class RobustLoss {
    kTukey,   // biweight: samples beyond the width get weight 0 (hard rejection)
    kCauchy,  // weight 1 / (1 + (r / width)^2): soft, never exactly 0
  };
  Method method = Method::kAdaptive;

  // Weights that turn intensity-divided RGB into luminance for the normal
  // solve; MATLAB rgb2gray by default. Each >= 0, sum > 0.
  std::array<double, 3> luminance_weights = {0.2989, 0.5870, 0.1140};

  // Fewest usable samples to solve a pixel, in [3, 1000].
  int min_lights = 3;

  // Largest accepted ratio of the light matrix's singular values, > 1.
  double max_condition_number = 100.0;

  // A sample whose luminance (before dividing by the light) is at or below
  // this is taken as shadowed (attached or cast: the Lambertian model does not
  // hold there) and left out, >= 0 in linear pixel units. 0 keeps every
  // sample (plain least squares). The default is about 20 sigma of the dark
  // noise of a 14-bit sensor.
  double min_sample_value = 0.002;

  // A light whose luminance-weighted intensity at a pixel is below this is not
  // used there (it cannot be divided out), >= 0, in linear pixel units.
  double min_light_intensity = 1e-6;

  // Scaled normals shorter than this are "no signal", >= 0 (albedo units).
  double min_albedo = 1e-4;

  // Worker threads; 0 = all hardware threads, in [0, 256].
  int num_threads = 0;

  // Solve the three colour channels for the albedo (else only the normal;
  // the albedo map is then left empty).
  bool compute_albedo = true;

  // Fill the condition-number and residual maps (else they are left empty;
  // status, lights_used and solve_path are always filled).
  bool compute_confidence = true;

  // Fill the specular maps (PhotometricSolution::specular) where the method
  // estimates a specular lobe (else, and for methods that do not, they are
  // left empty).
  bool compute_specular = true;

  // adaptive: its robust pass (see adaptive_robust_residual) fits the diffuse
  // + specular lobe model (FitDiffuseLobe, as diffuse_lobe) instead of the
  // Lambertian IRLS alone, and the specular maps are filled. (Kept beside the
  // other flags: the struct's size is a tripwire in solve_controller.cc.)
  bool adaptive_lobe = true;
  // adaptive with adaptive_lobe, RGB input: after the per-pixel passes, pixels
  // with a lobe are refined by one anisotropic lobe shared per block and albedo
  // group (RefineCoherentLobe, solver/coherent_lobe.h), where BIC prefers it.
  bool adaptive_coherent_lobe = true;
  // adaptive: where its robust pass runs, the learned network's normal
  // (solver/normal_network.h), refined on the samples that agree with it,
  // instead of the robust fit's: kNever, kUnsupportedLobe (where the lobe fit
  // keeps no lobe: the pixel would get the robust Lambertian fit) or kFlagged
  // (every pixel of the robust pass).
  // Only with at most adaptive_learned_max_lights lights (at DiLiGenT's 96 the
  // network lost to the robust fit on four of five validation objects: a limit
  // set after looking at them) and on pixels with at least 6 tokens (the
  // fewest the network was trained on). kNever by default: on the simulated
  // near-field draped folders it raised the refined error (0.67 -> 1.50 deg at
  // 320x240) and it is not exact on three lights (docs/solver.md, "Learned normals").
  enum class LearnedUse : uint8_t { kNever, kUnsupportedLobe, kFlagged };
  LearnedUse adaptive_learned = LearnedUse::kNever;
  int adaptive_learned_max_lights = 24;
  // learned, and adaptive's network pixels: the network's normal re-solved by
  // least squares on the samples that agree with it, where that stays near it.
  // Off: on the synthetic validation sets it helps only Lambertian pixels
  // (1.93 -> 1.34 deg) and costs the specular and sheen ones more
  // (scripts/train/evaluate_refit.py; docs/solver.md, "Learned normals").
  bool learned_refine = false;

  // adaptive: pixels left to least squares whose residual carries a velvet
  // sheen's pattern (SheenPatternInResidual) are re-solved with the diffuse +
  // velvet sheen model (FitDiffuseSheen, pixel_solvers.h), kept where BIC prefers it.
  // Off by default: it helps the simulated cloth but fits noise on Lambertian
  // scenes (docs/solver.md, "Velvet sheen").
  bool adaptive_sheen = false;
  // adaptive, at most CoherentSheenOptions::max_lights lights: after the
  // per-pixel passes, the least-squares pixels of a block and albedo group
  // are re-solved under one velvet sheen fitted to all of them, where the
  // group's samples together support it (RefineCoherentSheen,
  // solver/coherent_sheen.h; RGB and Bayer-domain input).
  bool adaptive_coherent_sheen = true;

  // Side of the square tiles the image is solved in, pixels, in [8, 4096].
  // Bounds the scratch memory per thread and is the unit of the light-field
  // checks below.
  int tile_size = 128;

  // adaptive: a tile whose lights differ from those at its centre by at most
  // this (direction in radians, intensity relative) shares one light matrix;
  // otherwise its lights are interpolated bilinearly from its corners when
  // that is within this tolerance at the checked points, else evaluated per
  // pixel. Also the tolerance uniform_pinv checks the whole image against.
  // In [0, 0.1]; 0 = exact only.
  double light_tolerance = 1e-4;

  // --- robust_irls, sparse_bayesian and the robust pass of adaptive ---
  RobustLoss robust_loss = RobustLoss::kTukey;
  // Loss width in units of the robust residual scale (1.4826 x median
  // absolute residual); 0 = the loss's standard 95 %-efficiency width
  // (Tukey 4.685, Cauchy 2.385). >= 0.
  double robust_loss_width = 0;
  // Floor of the residual scale, relative to the pixel's albedo, > 0:
  // residuals below it are noise, never outliers.
  double robust_min_scale = 0.01;
  // Iteration limit of IRLS and sparse Bayesian learning, in [1, 10000].
  int robust_max_iterations = 50;
  // A sample whose intensity-divided luminance is below this fraction of
  // the pixel's brightest one is left out before the robust solve (the dark
  // rim of attached and cast shadows that a threshold on the value misses),
  // in [0, 1). 0 = off.
  double robust_dark_fraction = 0.0;
  // adaptive: re-solve robustly where the least-squares RMS residual,
  // relative to the albedo, is above this, >= 0. A pixel whose samples were
  // clipped (sample_valid) is always re-solved.
  double adaptive_robust_residual = 0.02;

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

// From the method table (solver/photometric_methods.h): "adaptive",
// "jacobi_svd", ... (the names the CLI and reports use); the inverse, which
// throws std::invalid_argument listing the valid names; every method in the
// table's order.
const char* PhotometricMethodName(PhotometricSolverOptions::Method method);
PhotometricSolverOptions::Method PhotometricMethodFromName(const std::string& name);
std::vector<PhotometricSolverOptions::Method> AllPhotometricMethods();

struct BayerSolverInput;
struct PhotometricSolution;

struct PhotometricSolverInput {
  // One linear RGB image per light (3 channels, dark frame subtracted), in the
  // order of the light field's lights.
  std::vector<const ImageF*> images;
  // Optional, one per light (1 channel): 0 marks an unusable sample (clipped).
  std::vector<const ImageU8*> sample_valid;
  const LightField* light_field = nullptr;
  // Optional (1 channel): pixels to solve are non-zero; the rest get
  // kOutsideRegion. Only the tiles that meet the region are worked on.
  const ImageU8* region = nullptr;
  // Optional, both or neither (RAW sessions' blend, solver/bayer_normal_blend.h):
  // the raw mosaics of the same frames (their light field and region are
  // this input's); the shared-lobe pass (RefineCoherentLobe) then also
  // re-solves every pixel it refines from the pixel's own CFA samples under
  // the same lobe, into *lobe_bayer (the Bayer-domain normals the blend
  // weighs on lobe pixels).
  const BayerSolverInput* lobe_mosaics = nullptr;
  PhotometricSolution* lobe_bayer = nullptr;
};

// Bayer-domain input: the normal is solved at every raw pixel from its own
// CFA channel, and only the albedo is demosaiced (bilinearly) at the end.
struct BayerSolverInput {
  // One mosaic per light (1 channel): linear, dark subtracted, in the units of
  // the light field's intensities for that pixel's colour channel (white
  // balance is applied per CFA channel by dividing by that intensity).
  std::vector<const ImageF*> mosaics;
  // Colour channel (0 = R, 1 = G, 2 = B) at the four positions of the 2x2 CFA
  // tile, row-major: (0,0), (1,0), (0,1), (1,1). RGGB = {0, 1, 1, 2}.
  std::array<int, 4> cfa_channels = {0, 1, 1, 2};
  std::vector<const ImageU8*> sample_valid;  // optional, as PhotometricSolverInput
  const LightField* light_field = nullptr;
  const ImageU8* region = nullptr;           // optional, as PhotometricSolverInput
  // Optional (1 channel): the shared velvet sheen (adaptive_coherent_sheen)
  // only on these pixels, e.g. those a demosaiced solve of the same frames
  // re-solved under it (PhotometricSolution::coherent_sheen): one raw sample
  // per light carries too little colour for its dichromatic test.
  const ImageU8* sheen_pixels = nullptr;
};

struct PhotometricSolution {
  ImageF normal_in_table;   // 3 channels, unit; (0, 0, 1) where not solved
  ImageF albedo;            // 3 channels, linear; 0 where not solved
  ImageU8 status;           // PixelStatus per pixel
  ImageU8 lights_used;      // samples in the solve (robust: with non-zero weight)
  ImageF condition_number;  // of the light matrix; 0 where not computed
  ImageF residual;          // RMS luminance residual relative to the albedo
  ImageU8 solve_path;       // SolvePath per pixel
  // Specular lobe, only from methods that estimate one (else both empty):
  // 2 channels, specular_f0 (white reflectance at normal incidence, [0, 1])
  // and roughness_alpha (GGX alpha, (0, 1]); both 0 unless kEstimated.
  ImageF specular;
  ImageU8 specular_status;  // SpecularStatus per pixel
  // 1 where the pixel was re-solved under a velvet sheen shared by its block
  // (adaptive_coherent_sheen), else 0; empty unless that pass ran.
  ImageU8 coherent_sheen;
  // The learned network's own estimate of its angular error (deg) where its
  // normal was kept (SolvePath::kLearned), else 0; empty unless a solve with
  // confidence ran the network.
  ImageF learned_error_deg;
};

struct PhotometricSolverSummary : AlgorithmSummary {
  std::string method;                 // PhotometricMethodName of the method that ran
  bool bayer_domain = false;          // solved per raw pixel (SolvePhotometricStereoBayer)
  int num_lights = 0;
  int num_threads = 0;
  std::string kernel_isa;             // KernelIsaName of the hot loops that ran
  size_t num_pixels = 0;
  size_t num_tiles = 0;               // tiles of the image
  size_t tiles_skipped = 0;           // tiles with no pixel in the region: not touched
  std::array<size_t, kNumPixelStatuses> pixels_by_status{};
  std::array<size_t, kNumSolvePaths> pixels_by_path{};
  std::array<size_t, kNumSpecularStatuses> pixels_by_specular{};  // all 0 when no specular maps were made
  size_t pixels_coherent_lobe = 0;    // pixels whose result is the shared lobe's (adaptive_coherent_lobe)
  size_t pixels_coherent_sheen = 0;   // pixels re-solved under a shared velvet sheen (adaptive_coherent_sheen)
  // Raw sessions' default (BlendBayerNormals, solver/bayer_normal_blend.h, run
  // by the banded solve): pixels whose normal took a share of a Bayer-domain
  // solve's, and that share's mean over the pixels it was weighed on (those
  // the gate left out, SelectBayerBlendCells, at 0); the pixels the
  // Bayer-domain solve ran on (the gate's cells).
  size_t pixels_bayer_blended = 0;
  double bayer_blend_mean_weight = 0;
  size_t pixels_bayer_solved = 0;
  // Of the shared lobe's pixels, those whose normal is its re-solve from
  // their own raw samples (PhotometricSolverInput::lobe_mosaics, the blend).
  size_t pixels_bayer_lobe = 0;
  // The learned network, where the solve ran it (SolverPass::kLearnedNormals):
  // the model file it was built from and that file's SHA-256; else empty.
  std::string learned_model;
  std::string learned_model_sha256;
  double seconds = 0;

  size_t num_solved() const { return pixels_by_status[0]; }
  std::string BriefReport() const;
};

// Input shapes that do not fit together throw std::invalid_argument before any
// work; a cancelled solve returns Termination::kCancelled and a partial
// solution whose unsolved pixels are not marked kSolved.
PhotometricSolverSummary SolvePhotometricStereo(const PhotometricSolverOptions& options,
                                                const PhotometricSolverInput& input,
                                                PhotometricSolution* solution,
                                                const ProgressCallback& progress = {});

// The same on raw Bayer mosaics (see BayerSolverInput).
PhotometricSolverSummary SolvePhotometricStereoBayer(const PhotometricSolverOptions& options,
                                                     const BayerSolverInput& input,
                                                     PhotometricSolution* solution,
                                                     const ProgressCallback& progress = {});

}  // namespace scanbench
