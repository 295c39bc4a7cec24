// Per-pixel Lambertian photometric stereo: (n . l) k_d i = I.
//
// Each sample is first divided by the light's intensity at the pixel, giving
// I' = N . l with N = k_d n (the scaled normal). One least-squares solve on
// luminance gives the normal; one per colour channel gives the albedo as the
// length of that channel's scaled normal.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "solver/image.h"
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
  kInvalidInput = 6,     // non-finite sample or light value
};
inline constexpr int kNumPixelStatuses = 7;
const char* PixelStatusName(PixelStatus status);

struct PhotometricSolverOptions {
  enum class Method {
    kJacobiSvd,  // reference: per-pixel two-sided Jacobi SVD (Eigen::JacobiSVD)
  };
  Method method = Method::kJacobiSvd;

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

  // Solve the three colour channels for the albedo (else only the normal).
  bool compute_albedo = true;

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

struct PhotometricSolverInput {
  // One linear RGB image per light (3 channels, dark frame subtracted), in the
  // order of the light field's lights.
  std::vector<const ImageF*> images;
  // Optional, one per light (1 channel): 0 marks an unusable sample (clipped).
  std::vector<const ImageU8*> sample_valid;
  const LightField* light_field = nullptr;
  // Optional (1 channel): pixels to solve are non-zero; the rest get kOutsideRegion.
  const ImageU8* region = nullptr;
};

struct PhotometricSolution {
  ImageF normal_in_table;   // 3 channels, unit; (0, 0, 1) where not solved
  ImageF albedo;            // 3 channels, linear; 0 where not solved
  ImageU8 status;           // PixelStatus per pixel
  ImageU8 lights_used;      // samples in the solve
  ImageF condition_number;  // of the light matrix; 0 where not computed
  ImageF residual;          // RMS luminance residual relative to the albedo
};

struct PhotometricSolverSummary {
  enum class Termination { kSuccess, kCancelled, kFailure };
  Termination termination = Termination::kFailure;
  std::string message;
  int num_lights = 0;
  int num_threads = 0;
  size_t num_pixels = 0;
  std::array<size_t, kNumPixelStatuses> pixels_by_status{};
  double seconds = 0;

  size_t num_solved() const { return pixels_by_status[0]; }
  bool IsSolutionUsable() const { return termination == Termination::kSuccess; }
  std::string BriefReport() const;
};

// Called with the fraction done in [0, 1]; returning false cancels the solve.
using ProgressCallback = std::function<bool(double fraction_done)>;

// Input shapes that do not fit together throw std::invalid_argument before any
// work; a cancelled solve returns Termination::kCancelled and a partial
// solution whose unsolved pixels are not marked kSolved.
PhotometricSolverSummary SolvePhotometricStereo(const PhotometricSolverOptions& options,
                                                const PhotometricSolverInput& input,
                                                PhotometricSolution* solution,
                                                const ProgressCallback& progress = {});

}  // namespace scanbench
