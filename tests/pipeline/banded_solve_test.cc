#include "pipeline/banded_solve.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "pipeline/depth_refinement.h"
#include "solver/synthetic_scene.h"

namespace scanbench {
namespace {

constexpr uint16_t kBlack = 600, kWhite = 16383;

// A linear RGB render as an RGGB mosaic over a noisy dark level; the specular
// highlights clip.
RawImage Mosaic(const ImageF& rgb, const ImageU16& dark_level) {
  RawImage raw;
  raw.mosaic = ImageU16(rgb.width(), rgb.height(), 1);
  raw.cfa = CfaPattern::kRGGB;
  raw.black_level = {kBlack, kBlack, kBlack, kBlack};
  raw.white_level = kWhite;
  for (int y = 0; y < rgb.height(); ++y) {
    for (int x = 0; x < rgb.width(); ++x) {
      const double value = rgb(x, y, CfaColorAt(raw.cfa, x, y)) * (kWhite - kBlack) * 0.8;
      raw.mosaic(x, y) = static_cast<uint16_t>(std::clamp(dark_level(x, y) + value, 0.0, double(kWhite)));
    }
  }
  return raw;
}

struct RawScene {
  SyntheticScene scene;
  RawImage dark;
  std::vector<RawImage> frames;
  RawFrameStack Stack() const {
    RawFrameStack stack;
    stack.dark = &dark;
    for (const RawImage& frame : frames) stack.frames.push_back(&frame);
    stack.exposure_scales.assign(frames.size(), 1.0);
    stack.exposure_scales[3] = 0.5;  // an imported frame exposed twice as long
    return stack;
  }
};

RawScene MakeRawScene() {
  SyntheticSceneOptions options;
  options.width = 203;
  options.height = 171;  // bands that end mid-tile at the bottom
  options.lights = SyntheticSceneOptions::Lights::kNearField;
  options.light_distance = 400;
  options.specular = 0.6;
  options.noise_stddev = 0.002;
  options.seed = 11;
  RawScene raw{MakeSyntheticScene(options), {}, {}};
  ImageU16 dark_level(options.width, options.height, 1);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(kBlack + 20, 4);
  for (size_t i = 0; i < dark_level.size(); ++i) dark_level.data()[i] = static_cast<uint16_t>(std::lround(noise(rng)));
  raw.dark = Mosaic(ImageF(options.width, options.height, 3, 0.0f), dark_level);
  for (const ImageF& image : raw.scene.images) raw.frames.push_back(Mosaic(image, dark_level));
  return raw;
}

template <typename T>
void ExpectSameBits(const Image<T>& banded, const Image<T>& whole, const char* name) {
  ASSERT_EQ(banded.width(), whole.width()) << name;
  ASSERT_EQ(banded.height(), whole.height()) << name;
  ASSERT_EQ(banded.channels(), whole.channels()) << name;
  EXPECT_EQ(std::memcmp(banded.data(), whole.data(), sizeof(T) * whole.size()), 0) << name << " differs";
}

// Today's solve's input: every frame developed whole, exposure scaled.
std::vector<DevelopedFrame> DevelopWhole(const RawScene& raw, const RawFrameStack& stack,
                                         const RawDevelopOptions& develop, size_t* clipped) {
  std::vector<DevelopedFrame> developed;
  for (size_t k = 0; k < raw.frames.size(); ++k) {
    developed.push_back(DevelopRaw(raw.frames[k], &raw.dark, develop));
    *clipped += developed.back().num_clipped_samples;
    float* values = developed.back().rgb.data();
    for (size_t i = 0; i < developed.back().rgb.size(); ++i) {
      values[i] = static_cast<float>(values[i] * stack.exposure_scales[k]);
    }
  }
  return developed;
}

// The whole-frame Bayer solver's input from developed frames: each mosaic
// scaled by its frame's exposure, as the banded solve does.
BayerSolverInput ScaledBayerInput(const RawFrameStack& stack, const LightField& light_field,
                                  std::vector<DevelopedFrame>* developed) {
  BayerSolverInput input;
  for (size_t k = 0; k < developed->size(); ++k) {
    DevelopedFrame& frame = (*developed)[k];
    float* values = frame.mosaic.data();
    for (size_t i = 0; i < frame.mosaic.size(); ++i) {
      values[i] = static_cast<float>(values[i] * stack.exposure_scales[k]);
    }
    input.mosaics.push_back(&frame.mosaic);
    input.sample_valid.push_back(&frame.mosaic_valid);
  }
  input.cfa_channels = {0, 1, 1, 2};  // RGGB
  input.light_field = &light_field;
  return input;
}

TEST(BandedSolveTest, EqualsTheFullFrameSolveBitForBit) {
  const RawScene raw = MakeRawScene();
  const RawFrameStack stack = raw.Stack();
  BandedSolveOptions options;
  options.solver.tile_size = 32;
  options.solver.num_threads = 2;
  options.band_rows = 40;  // rounded up to 64: two whole tile rows per band

  size_t clipped = 0;
  const std::vector<DevelopedFrame> developed = DevelopWhole(raw, stack, options.develop, &clipped);
  PhotometricSolverInput input;
  for (const DevelopedFrame& frame : developed) {
    input.images.push_back(&frame.rgb);
    input.sample_valid.push_back(&frame.valid);
  }
  input.light_field = raw.scene.light_field.get();
  PhotometricSolution whole;
  const PhotometricSolverSummary whole_summary = SolvePhotometricStereo(options.solver, input, &whole);
  ASSERT_TRUE(whole_summary.IsUsable()) << whole_summary.message;

  PhotometricSolution banded;
  const BandedSolveSummary summary = SolveBanded(options, stack, *raw.scene.light_field, &banded);
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  EXPECT_EQ(summary.band_rows, 64);
  EXPECT_EQ(summary.num_bands, 3);
  // The scene exercises what crosses a band border: clipped highlights, the
  // lobe passes, near-field lights.
  EXPECT_GT(clipped, 0u);
  EXPECT_GT(whole_summary.pixels_coherent_lobe + whole_summary.pixels_by_path[int(SolvePath::kRobust)], 0u);
  EXPECT_EQ(summary.clipped_samples, clipped);
  ExpectSameBits(banded.normal_in_table, whole.normal_in_table, "normal_in_table");
  ExpectSameBits(banded.albedo, whole.albedo, "albedo");
  ExpectSameBits(banded.status, whole.status, "status");
  ExpectSameBits(banded.lights_used, whole.lights_used, "lights_used");
  ExpectSameBits(banded.condition_number, whole.condition_number, "condition_number");
  ExpectSameBits(banded.residual, whole.residual, "residual");
  ExpectSameBits(banded.solve_path, whole.solve_path, "solve_path");
  ExpectSameBits(banded.specular, whole.specular, "specular");
  ExpectSameBits(banded.specular_status, whole.specular_status, "specular_status");
  EXPECT_EQ(summary.solver.num_pixels, whole_summary.num_pixels);
  EXPECT_EQ(summary.solver.pixels_by_status, whole_summary.pixels_by_status);
  EXPECT_EQ(summary.solver.pixels_by_path, whole_summary.pixels_by_path);
  EXPECT_EQ(summary.solver.pixels_by_specular, whole_summary.pixels_by_specular);
  EXPECT_EQ(summary.solver.pixels_coherent_lobe, whole_summary.pixels_coherent_lobe);
  EXPECT_EQ(summary.solver.num_tiles, whole_summary.num_tiles);
  EXPECT_FALSE(summary.solver.kernel_isa.empty());  // the report's "(avx2 kernels)", not "?"
  EXPECT_EQ(summary.solver.kernel_isa, whole_summary.kernel_isa);
}

// The depth refinement's shadow-edge masks made per band from the band and its
// margin equal those made on the whole frames.
TEST(BandedSolveTest, SampleMasksFromBandsWithMarginEqualWholeFrameMasks) {
  const RawScene raw = MakeRawScene();
  const RawFrameStack stack = raw.Stack();
  BandedSolveOptions options;
  options.solver.tile_size = 32;
  options.solver.num_threads = 2;
  options.band_rows = 64;
  DepthRefinementOptions depth;
  depth.shadow_edge_radius_px = 2;
  depth.shadow_edge_level = 0.02;  // the sphere's dark side and the black background

  size_t clipped = 0;
  const std::vector<DevelopedFrame> developed = DevelopWhole(raw, stack, options.develop, &clipped);
  PhotometricSolverInput input;
  for (const DevelopedFrame& frame : developed) {
    input.images.push_back(&frame.rgb);
    input.sample_valid.push_back(&frame.valid);
  }
  size_t whole_left_out = 0;
  const std::vector<ImageU8> masks = ShadowEdgeSampleMasks(depth, options.solver, input, &whole_left_out);
  input.sample_valid.clear();
  for (const ImageU8& mask : masks) input.sample_valid.push_back(&mask);
  input.light_field = raw.scene.light_field.get();
  PhotometricSolution whole;
  ASSERT_TRUE(SolvePhotometricStereo(options.solver, input, &whole).IsUsable());

  options.sample_mask_margin_rows = depth.shadow_edge_radius_px;
  options.sample_masks = [&](const PhotometricSolverInput& band) {
    return ShadowEdgeSampleMasks(depth, options.solver, band);
  };
  PhotometricSolution banded;
  const BandedSolveSummary summary = SolveBanded(options, stack, *raw.scene.light_field, &banded);
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  EXPECT_EQ(summary.num_bands, 3);
  EXPECT_GT(whole_left_out, 0u);
  EXPECT_EQ(summary.samples_masked_out, whole_left_out);
  ExpectSameBits(banded.normal_in_table, whole.normal_in_table, "normal_in_table");
  ExpectSameBits(banded.albedo, whole.albedo, "albedo");
  ExpectSameBits(banded.status, whole.status, "status");
  ExpectSameBits(banded.lights_used, whole.lights_used, "lights_used");

  // A hook that gives the wrong number of masks is refused by name.
  options.sample_masks = [](const PhotometricSolverInput&) { return std::vector<ImageU8>(1); };
  EXPECT_THAT([&] { SolveBanded(options, stack, *raw.scene.light_field, &banded); },
              testing::ThrowsMessage<std::invalid_argument>(testing::HasSubstr("sample_masks gave 1 masks")));
}

// Bayer domain: each band is solved with its 2-row margin inside a window one
// tile larger on each side (the whole-frame solve's tiles), then cropped; the
// counts are the bands' own.
TEST(BandedSolveTest, BayerDomainBandsMatchTheWholeFrameBayerSolve) {
  const RawScene raw = MakeRawScene();
  const RawFrameStack stack = raw.Stack();
  BandedSolveOptions options;
  options.solver.tile_size = 32;
  options.solver.num_threads = 2;
  options.band_rows = 32;  // borders every 32 rows, several of them through clipped highlights
  options.bayer_domain = true;

  RawDevelopOptions develop = options.develop;
  develop.keep_mosaic = true;
  size_t clipped = 0;
  std::vector<DevelopedFrame> developed = DevelopWhole(raw, stack, develop, &clipped);
  const BayerSolverInput input = ScaledBayerInput(stack, *raw.scene.light_field, &developed);
  PhotometricSolution whole;
  const PhotometricSolverSummary whole_summary = SolvePhotometricStereoBayer(options.solver, input, &whole);
  ASSERT_TRUE(whole_summary.IsUsable()) << whole_summary.message;

  PhotometricSolution banded;
  const BandedSolveSummary summary = SolveBanded(options, stack, *raw.scene.light_field, &banded);
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  EXPECT_TRUE(summary.solver.bayer_domain);
  EXPECT_EQ(summary.num_bands, 6);
  // Clipped samples near the band borders (in a margin) are counted once.
  size_t clipped_near_borders = 0;
  for (const DevelopedFrame& frame : developed) {
    for (int border = 32; border < frame.mosaic_valid.height(); border += 32) {
      for (int y = border - kBayerMarginRows; y < border + kBayerMarginRows; ++y) {
        const uint8_t* flags = frame.mosaic_valid.row(y);
        clipped_near_borders += std::count(flags, flags + frame.mosaic_valid.width(), uint8_t{0});
      }
    }
  }
  EXPECT_GT(clipped_near_borders, 0u);
  EXPECT_EQ(summary.clipped_samples, clipped);
  EXPECT_EQ(summary.solver.num_pixels, whole_summary.num_pixels);
  ExpectSameBits(banded.normal_in_table, whole.normal_in_table, "normal_in_table");
  ExpectSameBits(banded.albedo, whole.albedo, "albedo");
  ExpectSameBits(banded.status, whole.status, "status");
  ExpectSameBits(banded.lights_used, whole.lights_used, "lights_used");
  ExpectSameBits(banded.residual, whole.residual, "residual");
  ExpectSameBits(banded.solve_path, whole.solve_path, "solve_path");
  EXPECT_EQ(summary.solver.pixels_by_status, whole_summary.pixels_by_status);
  EXPECT_EQ(summary.solver.pixels_by_path, whole_summary.pixels_by_path);
  size_t by_status = 0;
  for (size_t n : summary.solver.pixels_by_status) by_status += n;
  EXPECT_EQ(by_status, whole.status.num_pixels());

  options.sample_masks = [](const PhotometricSolverInput&) { return std::vector<ImageU8>(); };
  EXPECT_THROW(SolveBanded(options, stack, *raw.scene.light_field, &banded), std::invalid_argument);
}

// The default on raw sessions (issue #13): each band solved twice and its
// normals blended; the bands give the whole frame's blend bit for bit.
TEST(BandedSolveTest, BayerBlendBandsMatchTheWholeFrameBlend) {
  const RawScene raw = MakeRawScene();
  const RawFrameStack stack = raw.Stack();
  BandedSolveOptions options;
  options.solver.tile_size = 32;
  options.solver.num_threads = 2;
  options.band_rows = 32;
  options.bayer_blend = true;

  RawDevelopOptions develop = options.develop;
  develop.keep_mosaic = true;
  size_t clipped = 0;
  std::vector<DevelopedFrame> developed = DevelopWhole(raw, stack, develop, &clipped);
  const BayerSolverInput bayer_input = ScaledBayerInput(stack, *raw.scene.light_field, &developed);
  PhotometricSolverInput rgb_input;
  for (const DevelopedFrame& frame : developed) {
    rgb_input.images.push_back(&frame.rgb);
    rgb_input.sample_valid.push_back(&frame.valid);
  }
  rgb_input.light_field = raw.scene.light_field.get();
  // The shared lobe's pixels re-solved from their raw samples, as the banded blend does.
  PhotometricSolution whole, bayer, lobe_bayer;
  rgb_input.lobe_mosaics = &bayer_input;
  rgb_input.lobe_bayer = &lobe_bayer;
  const PhotometricSolverSummary whole_summary = SolvePhotometricStereo(options.solver, rgb_input, &whole);
  ASSERT_TRUE(whole_summary.IsUsable()) << whole_summary.message;
  // The Bayer solve as the banded one runs it: no lobe, the sheen as asked (off).
  PhotometricSolverOptions bayer_solver = options.solver;
  bayer_solver.adaptive_lobe = false;
  bayer_solver.adaptive_coherent_lobe = false;
  bayer_solver.compute_specular = false;
  bayer_solver.compute_albedo = false;
  // The shared sheen only where the demosaiced solve took it, as the banded
  // solve hands it over.
  BayerSolverInput fed_input = bayer_input;
  fed_input.sheen_pixels = &whole.coherent_sheen;
  ASSERT_TRUE(SolvePhotometricStereoBayer(bayer_solver, fed_input, &bayer).IsUsable());
  const PhotometricSolution demosaiced = whole;
  BayerNormalBlendOptions blend;
  blend.num_threads = 2;
  blend.lobe_bayer = &lobe_bayer;
  // Only on the cells the demosaiced solve selects (the gate), and there
  // each pixel as the Bayer solve of the whole frame gives it.
  const BayerBlendCellsSummary cells = SelectBayerBlendCells(blend, demosaiced, *raw.scene.light_field);
  ASSERT_TRUE(cells.IsUsable()) << cells.message;
  ASSERT_GT(cells.blocks_open, 0u) << cells.BriefReport();          // the test would be empty otherwise
  ASSERT_LT(cells.blocks_open, cells.blocks) << cells.BriefReport();  // and the gate untested
  BayerSolverInput gated_input = fed_input;
  const ImageU8 region = BayerBlendRegion(cells.cells, blend.cell_size, whole.status.width(), whole.status.height());
  gated_input.region = &region;
  PhotometricSolution gated_bayer;
  const PhotometricSolverSummary gated_summary = SolvePhotometricStereoBayer(bayer_solver, gated_input, &gated_bayer);
  ASSERT_TRUE(gated_summary.IsUsable()) << gated_summary.message;
  for (int y = 0; y < region.height(); ++y) {
    for (int x = 0; x < region.width(); ++x) {
      if (region(x, y) == 0) continue;
      ASSERT_EQ(gated_bayer.status(x, y), bayer.status(x, y)) << x << ", " << y;
      for (int c = 0; c < 3; ++c) ASSERT_EQ(gated_bayer.normal_in_table(x, y, c), bayer.normal_in_table(x, y, c));
      ASSERT_EQ(gated_bayer.residual(x, y), bayer.residual(x, y));
    }
  }
  const BayerNormalBlendSummary blended = BlendBayerNormals(blend, gated_bayer, *raw.scene.light_field, &whole);
  ASSERT_TRUE(blended.IsUsable()) << blended.message;
  ASSERT_GT(blended.pixels_blended, 0u);  // the test would be empty otherwise

  PhotometricSolution banded;
  std::vector<double> fractions;
  const BandedSolveSummary summary =
      SolveBanded(options, stack, *raw.scene.light_field, &banded, [&](double fraction) {
        fractions.push_back(fraction);
        return true;
      });
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  // The progress of the two solves and the blend runs forward to 1.
  ASSERT_FALSE(fractions.empty());
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_GE(fractions.front(), 0.0);
  EXPECT_DOUBLE_EQ(fractions.back(), 1.0);
  EXPECT_EQ(summary.num_bands, 6);
  EXPECT_EQ(summary.clipped_samples, clipped);
  EXPECT_EQ(summary.solver.pixels_bayer_blended, blended.pixels_blended);
  EXPECT_EQ(summary.solver.pixels_bayer_solved,
            region.size() - std::count(region.data(), region.data() + region.size(), uint8_t{0}));
  // The mean weight counts the pixels the gate left out, at 0.
  EXPECT_NEAR(summary.solver.bayer_blend_mean_weight,
              blended.mean_weight * blended.pixels_weighed / double(blended.pixels_weighed + cells.pixels_left_out),
              1e-12);
  ExpectSameBits(banded.normal_in_table, whole.normal_in_table, "normal_in_table");
  // Everything but the normals is the demosaiced solve's.
  ExpectSameBits(banded.albedo, demosaiced.albedo, "albedo");
  ExpectSameBits(banded.status, demosaiced.status, "status");
  ExpectSameBits(banded.residual, demosaiced.residual, "residual");
  ExpectSameBits(banded.specular, demosaiced.specular, "specular");
  EXPECT_EQ(summary.solver.pixels_by_status, whole_summary.pixels_by_status);
  // The cell weights come back for the whole frame, as the whole-frame blend's.
  ExpectSameBits(summary.bayer_blend_weights, blended.cell_weights, "bayer_blend_weights");

  // Given back (the depth loop's frozen weights) they give the same blend;
  // given as 0 they keep the demosaiced normals, as 1 the Bayer ones; the
  // shared lobe's pixels take their raw re-solve whatever the weights.
  const ImageF estimated = summary.bayer_blend_weights;
  options.bayer_blend_weights = &estimated;
  PhotometricSolution frozen;
  const BandedSolveSummary frozen_summary = SolveBanded(options, stack, *raw.scene.light_field, &frozen);
  ASSERT_TRUE(frozen_summary.IsUsable()) << frozen_summary.message;
  ExpectSameBits(frozen.normal_in_table, whole.normal_in_table, "normal_in_table, frozen weights");
  ExpectSameBits(frozen_summary.bayer_blend_weights, estimated, "bayer_blend_weights, frozen");
  const ImageF zeros(estimated.width(), estimated.height(), 1, 0.0f);
  options.bayer_blend_weights = &zeros;
  ASSERT_TRUE(SolveBanded(options, stack, *raw.scene.light_field, &frozen).IsUsable());
  PhotometricSolution kept = demosaiced;
  ASSERT_TRUE(lobe_bayer.status.SameSize(kept.status.width(), kept.status.height()));
  size_t lobe_taken = 0;
  for (int y = 0; y < kept.status.height(); ++y) {
    for (int x = 0; x < kept.status.width(); ++x) {
      if (demosaiced.specular_status(x, y) != uint8_t(SpecularStatus::kEstimated) ||
          lobe_bayer.status(x, y) != uint8_t(PixelStatus::kSolved) || lobe_bayer.lights_used(x, y) < 4) {
        continue;
      }
      for (int c = 0; c < 3; ++c) kept.normal_in_table(x, y, c) = lobe_bayer.normal_in_table(x, y, c);
      ++lobe_taken;
    }
  }
  EXPECT_EQ(lobe_taken, summary.solver.pixels_bayer_lobe);
  ExpectSameBits(frozen.normal_in_table, kept.normal_in_table, "normal_in_table, weights 0");
  const ImageF ones(estimated.width(), estimated.height(), 1, 1.0f);
  options.bayer_blend_weights = &ones;
  ASSERT_TRUE(SolveBanded(options, stack, *raw.scene.light_field, &frozen).IsUsable());
  size_t bayer_taken = 0, compared = 0;
  for (int y = 0; y < frozen.status.height(); ++y) {
    for (int x = 0; x < frozen.status.width(); ++x) {
      if (demosaiced.status(x, y) != uint8_t(PixelStatus::kSolved) || bayer.status(x, y) != uint8_t(PixelStatus::kSolved) ||
          demosaiced.specular_status(x, y) == uint8_t(SpecularStatus::kEstimated) || bayer.lights_used(x, y) < 4) {
        continue;
      }
      ++compared;
      bool same = true;
      for (int c = 0; c < 3; ++c) same &= std::abs(frozen.normal_in_table(x, y, c) - bayer.normal_in_table(x, y, c)) < 1e-6f;
      bayer_taken += same;
    }
  }
  ASSERT_GT(compared, 0u);
  EXPECT_EQ(bayer_taken, compared);
  // A grid of another size, or weights out of [0, 1], are refused.
  const ImageF small(estimated.width() - 1, estimated.height(), 1, 0.5f);
  options.bayer_blend_weights = &small;
  EXPECT_THROW(SolveBanded(options, stack, *raw.scene.light_field, &frozen), std::invalid_argument);
  const ImageF above(estimated.width(), estimated.height(), 1, 1.5f);
  options.bayer_blend_weights = &above;
  EXPECT_THROW(SolveBanded(options, stack, *raw.scene.light_field, &frozen), std::invalid_argument);
  options.bayer_blend_weights = nullptr;

  options.bayer_domain = true;
  EXPECT_THROW(SolveBanded(options, stack, *raw.scene.light_field, &banded), std::invalid_argument);
}

// The sink gets every band once, in order of rows, band-sized: together the
// whole solve's maps; an exception from it ends the solve and is rethrown.
TEST(BandedSolveTest, SinkGetsTheBandsOfTheWholeSolveInOrder) {
  const RawScene raw = MakeRawScene();
  BandedSolveOptions options;
  options.solver.tile_size = 32;
  options.band_rows = 64;
  PhotometricSolution whole;
  SolveBanded(options, raw.Stack(), *raw.scene.light_field, &whole);
  const int width = whole.status.width(), height = whole.status.height();
  int next_row = 0, bands = 0;
  const BandedSolveSummary summary = SolveBanded(
      options, raw.Stack(), *raw.scene.light_field,
      [&](int row0, PhotometricSolution& band) {
        EXPECT_EQ(row0, next_row);
        const int rows = band.status.height();
        EXPECT_EQ(rows, std::min(64, height - row0));
        EXPECT_EQ(band.status.width(), width);
        const PhotometricSolution expected = SolutionRows(whole, row0, rows);
        EXPECT_TRUE(std::equal(band.normal_in_table.data(), band.normal_in_table.data() + band.normal_in_table.size(),
                               expected.normal_in_table.data()));
        EXPECT_TRUE(std::equal(band.albedo.data(), band.albedo.data() + band.albedo.size(), expected.albedo.data()));
        EXPECT_TRUE(std::equal(band.status.data(), band.status.data() + band.status.size(), expected.status.data()));
        next_row += rows;
        ++bands;
      });
  EXPECT_TRUE(summary.IsUsable());
  EXPECT_EQ(next_row, height);
  EXPECT_EQ(bands, summary.num_bands);
  EXPECT_GE(bands, 3);
  EXPECT_THROW(SolveBanded(options, raw.Stack(), *raw.scene.light_field,
                           [](int, PhotometricSolution&) { throw std::runtime_error("disk full"); }),
               std::runtime_error);
}

TEST(BandedSolveTest, StopsWhenCancelledAndRejectsBadInput) {
  const RawScene raw = MakeRawScene();
  BandedSolveOptions options;
  options.solver.tile_size = 32;
  options.band_rows = 32;
  int calls = 0;
  PhotometricSolution solution;
  const BandedSolveSummary cancelled =
      SolveBanded(options, raw.Stack(), *raw.scene.light_field, &solution, [&](double) { return ++calls < 4; });
  EXPECT_TRUE(cancelled.IsCancelled());
  EXPECT_TRUE(cancelled.solver.IsCancelled()) << "the solver's summary too: the depth refinement's re-solves read it";
  EXPECT_LT(cancelled.num_bands, 6);

  RawFrameStack short_stack = raw.Stack();
  short_stack.frames.pop_back();
  short_stack.exposure_scales.clear();
  EXPECT_THAT([&] { SolveBanded(options, short_stack, *raw.scene.light_field, &solution); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("9 frames for a light field of 10")));
  options.band_rows = 0;
  EXPECT_THAT([&] { SolveBanded(options, raw.Stack(), *raw.scene.light_field, &solution); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("band_rows = 0")));
}

// The live solve's frames developed whole while the capture runs
// (RawFrameStack::developed): the bands' rows copied from them give the
// solve of the bands developed in place, bit for bit, with a frame's exposure
// scale, clipped highlights, one frame left to the solve's own development,
// and with the Bayer blend (which also reads the kept mosaic).
TEST(BandedSolveTest, FramesDevelopedAheadGiveTheSameSolve) {
  const RawScene raw = MakeRawScene();
  for (const bool blend : {false, true}) {
    SCOPED_TRACE(blend ? "bayer blend" : "demosaiced");
    BandedSolveOptions options;
    options.solver.tile_size = 32;
    options.solver.num_threads = 2;
    options.band_rows = 32;
    options.bayer_blend = blend;
    const RawFrameStack stack = raw.Stack();
    PhotometricSolution in_place;
    const BandedSolveSummary in_place_summary = SolveBanded(options, stack, *raw.scene.light_field, &in_place);
    ASSERT_TRUE(in_place_summary.IsUsable()) << in_place_summary.message;

    std::vector<DevelopedFrame> ahead;
    for (const RawImage& frame : raw.frames) ahead.push_back(DevelopRaw(frame, &raw.dark, DevelopOptionsFor(options)));
    RawFrameStack with_ahead = raw.Stack();
    for (const DevelopedFrame& frame : ahead) with_ahead.developed.push_back(&frame);
    with_ahead.developed[1] = nullptr;  // developed by the solve
    PhotometricSolution copied;
    const BandedSolveSummary copied_summary = SolveBanded(options, with_ahead, *raw.scene.light_field, &copied);
    ASSERT_TRUE(copied_summary.IsUsable()) << copied_summary.message;

    EXPECT_GT(in_place_summary.clipped_samples, 0u);
    EXPECT_EQ(copied_summary.clipped_samples, in_place_summary.clipped_samples);
    ExpectSameBits(copied.normal_in_table, in_place.normal_in_table, "normal_in_table");
    ExpectSameBits(copied.albedo, in_place.albedo, "albedo");
    ExpectSameBits(copied.status, in_place.status, "status");
    ExpectSameBits(copied.lights_used, in_place.lights_used, "lights_used");
    ExpectSameBits(copied.condition_number, in_place.condition_number, "condition_number");
    ExpectSameBits(copied.residual, in_place.residual, "residual");
    ExpectSameBits(copied.solve_path, in_place.solve_path, "solve_path");
    ExpectSameBits(copied.specular, in_place.specular, "specular");
    ExpectSameBits(copied.specular_status, in_place.specular_status, "specular_status");
    EXPECT_EQ(copied_summary.solver.pixels_by_path, in_place_summary.solver.pixels_by_path);
    EXPECT_EQ(copied_summary.solver.pixels_bayer_blended, in_place_summary.solver.pixels_bayer_blended);
    ExpectSameBits(copied_summary.bayer_blend_weights, in_place_summary.bayer_blend_weights, "blend weights");
  }

  // A frame developed ahead without the mosaic the blend needs, or of another size, is refused.
  BandedSolveOptions blend_options;
  blend_options.bayer_blend = true;
  RawDevelopOptions no_mosaic;
  const DevelopedFrame without_mosaic = DevelopRaw(raw.frames[0], &raw.dark, no_mosaic);
  RawFrameStack stack = raw.Stack();
  stack.developed.assign(raw.frames.size(), nullptr);
  stack.developed[0] = &without_mosaic;
  PhotometricSolution unused;
  EXPECT_THROW(SolveBanded(blend_options, stack, *raw.scene.light_field, &unused), std::invalid_argument);
  stack.developed.pop_back();
  EXPECT_THROW(SolveBanded(BandedSolveOptions(), stack, *raw.scene.light_field, &unused), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
