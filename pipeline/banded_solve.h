// The solve of a session's frames, band by band (issue #14): the frames stay
// raw uint16 Bayer mosaics; each band of rows is developed (dark subtraction,
// exposure scaling, clip marking, demosaic) into band-sized float buffers and
// solved there, through a view of the light field at the band's absolute
// pixel coordinates. Bands are whole solver tiles and whole coherent-lobe
// blocks, and the development reads kDevelopMarginRows beyond them, so the
// result equals SolvePhotometricStereo on the fully developed frames bit for
// bit (tests/pipeline/banded_solve_test.cc) while only one band of
// float RGB is held: 10 lights x 128 rows x 4928 px x 3 floats = 76 MB at
// 16 MP instead of 2 GB.
#pragma once

#include <functional>
#include <vector>

#include "calibration/raw_develop.h"
#include "calibration/raw_image.h"
#include "core/progress.h"
#include "core/summary.h"
#include "solver/bayer_normal_blend.h"
#include "solver/light_field.h"
#include "solver/photometric_solver.h"

namespace scanbench {

struct BandedSolveOptions {
  PhotometricSolverOptions solver;  // num_threads also runs the development
  RawDevelopOptions develop;
  // Rows per band, rounded up to whole solver tiles and coherent-lobe blocks
  // (BandRowsUnit), in [1, 65536]. More rows: fewer passes, more memory.
  int band_rows = 128;
  // Optional: each band's sample masks, made from the band developed with
  // sample_mask_margin_rows more rows on each side (fewer at the image's
  // edges), one mask per light of that size; null = the development's masks.
  // The depth refinement's re-solves leave out cast-shadow edges with it.
  std::function<std::vector<ImageU8>(const PhotometricSolverInput& band_with_margin)> sample_masks;
  int sample_mask_margin_rows = 0;  // rows, [0, 64]: at least the reach of sample_masks
  // Solve each raw pixel's normal from its own CFA sample
  // (SolvePhotometricStereoBayer); the band and kBayerMarginRows more rows on
  // each side (the albedo's demosaic at its borders reads its neighbours) are
  // solved in a window of whole tiles, so the result equals the whole-frame
  // Bayer solve. Not with sample_masks.
  bool bayer_domain = false;
  // Solve each band twice, on the demosaiced frames and in the Bayer domain
  // (Lambertian with Tukey weights: no specular lobe, whose pixels keep the
  // demosaiced normal anyway; the velvet sheen fit only with
  // solver.adaptive_sheen) on the cells the demosaiced solve's normals say
  // can take a weight (SelectBayerBlendCells), and blend each pixel's normal
  // between the two (BlendBayerNormals, solver/bayer_normal_blend.h; issue
  // #13); everything else is the demosaiced solve's. Bands are whole blend
  // cells and tiles, so the result is the whole-frame blend's. Not with
  // bayer_domain; with
  // sample_masks they apply to the demosaiced solve only (what they leave
  // out, the shadow edges a demosaic mixes into lit pixels, a raw sample does
  // not have).
  bool bayer_blend = false;
  // With bayer_blend, optional, not owned: the blend's cell weights for the
  // whole frame (BayerNormalBlendOptions::cell_weights; what an earlier
  // solve's summary returned as bayer_blend_weights) instead of estimating
  // them. Null = estimate.
  const ImageF* bayer_blend_weights = nullptr;
  // With bayer_blend: BayerNormalBlendOptions::gate_ratio, >= 0: the
  // Bayer-domain solve runs only on the cells whose demosaiced normals vary
  // beyond their noise (SelectBayerBlendCells); 0 = on every cell. With
  // bayer_blend_weights the cells are those given a weight above 0 instead.
  double bayer_blend_gate_ratio = BayerNormalBlendOptions().gate_ratio;
  void Check() const;
};

// The raw frames of a solve; pointers, not owned.
struct RawFrameStack {
  const RawImage* dark = nullptr;      // subtracted from every frame; null = each frame's black level
  std::vector<const RawImage*> frames;  // one per light, in the light field's order, all the same size and CFA
  // Per frame, what its developed values are multiplied by (an exposure that
  // differs from the session's); empty = 1 for all.
  std::vector<double> exposure_scales;
  // Optional, per frame (empty = none; a null entry = that frame is developed
  // as usual), not owned: the frame developed whole ahead of the solve
  // (DevelopRaw against `dark` with DevelopOptionsFor's options, no exposure
  // scale), e.g. by the live solve while the next frames are captured. The
  // solve then copies each band's rows from it instead of developing them:
  // the same values, since a band's development equals the whole frame's
  // rows (tests/calibration/raw_develop_test.cc).
  std::vector<const DevelopedFrame*> developed;
};

// The development SolveBanded runs with `options` (keep_mosaic when a
// Bayer-domain solve needs the mosaic): what a frame developed ahead
// (RawFrameStack::developed) must have been developed with.
RawDevelopOptions DevelopOptionsFor(const BandedSolveOptions& options);

// Rows beyond a band that a Bayer-domain band solve includes (even: the CFA phase holds).
inline constexpr int kBayerMarginRows = 2;

struct BandedSolveSummary : AlgorithmSummary {
  PhotometricSolverSummary solver;  // over all bands, as one solve would report it
  int num_bands = 0;
  int band_rows = 0;                // rows per band used (the last may have fewer)
  size_t clipped_samples = 0;       // raw samples at the clip level, all frames (0 with a sample_masks margin)
  size_t samples_masked_out = 0;    // usable samples that sample_masks made unusable, in the bands' own rows
  double develop_seconds = 0;       // of the wall time, developing
  double solve_seconds = 0;         // of the wall time, solving
  // With bayer_blend: the blend's cell weights over the whole frame (the
  // estimated ones, or bayer_blend_weights'); else empty.
  ImageF bayer_blend_weights;
  std::string BriefReport() const;
};

// Rows [first, first + rows) of every map of `solution` (a band as
// SolvedBandSink gets it, e.g. to stream a held solution band by band).
PhotometricSolution SolutionRows(const PhotometricSolution& solution, int first, int rows);

// Rows a band is a multiple of: the least common multiple of the solver's
// tile size and the coherent-lobe block size.
int BandRowsUnit(const PhotometricSolverOptions& solver);

// What SolveBanded hands each band to, in order of rows: the band's first
// row and its maps (rows [row0, row0 + band.status.height()), every map
// SolvePhotometricStereo fills, band-sized), also the band a failure or
// cancellation stopped in. The sink may change or move from `band`; an
// exception from it ends the solve and is rethrown.
using SolvedBandSink = std::function<void(int row0, PhotometricSolution& band)>;

// Solves `frames` under `light_field` (its size is the frames') and hands
// each band to `sink` as it is solved (the solve streams its maps to disk,
// solve_controller.h), so that no full-size solution needs to be held.
BandedSolveSummary SolveBanded(const BandedSolveOptions& options, const RawFrameStack& frames,
                               const LightField& light_field, const SolvedBandSink& sink,
                               const ProgressCallback& progress = {});

// The same with the bands copied into `solution` at full size. Throws std::invalid_argument on bad options
// (naming the field) or frames that do not fit together; a cancelled
// progress callback returns kCancelled with the bands not reached unsolved.
BandedSolveSummary SolveBanded(const BandedSolveOptions& options, const RawFrameStack& frames,
                               const LightField& light_field, PhotometricSolution* solution,
                               const ProgressCallback& progress = {});

}  // namespace scanbench
