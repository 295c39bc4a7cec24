#include "pipeline/banded_solve.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"
#include "solver/coherent_lobe.h"

namespace scanbench {
namespace {

// Rows [row0, row0 + height) of a light field, as a field of that height: the
// solver evaluates the whole field at absolute pixel coordinates, so its
// tiles see exactly the lights they see in a full-frame solve.
class LightFieldRows final : public LightField {
 public:
  LightFieldRows(const LightField& whole, int row0, int height) : whole_(whole), row0_(row0), height_(height) {}
  int num_lights() const override { return whole_.num_lights(); }
  int width() const override { return whole_.width(); }
  int height() const override { return height_; }
  void Evaluate(int x, int y, float* light_dirs, float* rgb_intensities) const override {
    whole_.Evaluate(x, y + row0_, light_dirs, rgb_intensities);
  }
  void EvaluateSpan(int x0, int y, int count, int stride, float* light_dirs, float* rgb_intensities) const override {
    whole_.EvaluateSpan(x0, y + row0_, count, stride, light_dirs, rgb_intensities);
  }
  bool IsUniform() const override { return whole_.IsUniform(); }
  void ViewDirection(int x, int y, float* view_dir) const override { whole_.ViewDirection(x, y + row0_, view_dir); }

 private:
  const LightField& whole_;
  int row0_, height_;
};

template <typename T>
void CopyRowsInto(const Image<T>& band, int row0, Image<T>* whole) {
  if (band.empty()) return;
  std::copy(band.data(), band.data() + band.size(), whole->row(row0));
}

// The solver's view of developed RGB frames (and their masks); points into `developed`.
PhotometricSolverInput RgbInput(const std::vector<DevelopedFrame>& developed) {
  PhotometricSolverInput input;
  for (const DevelopedFrame& frame : developed) {
    input.images.push_back(&frame.rgb);
    input.sample_valid.push_back(&frame.valid);
  }
  return input;
}

// Rows [first, first + rows) of an image.
template <typename T>
Image<T> CropRows(const Image<T>& image, int first, int rows) {
  Image<T> cropped(image.width(), rows, image.channels());
  std::copy(image.row(first), image.row(first) + cropped.size(), cropped.data());
  return cropped;
}

// The full-size maps, shaped as the first band's and filled as a solve leaves
// pixels it did not reach.
void AllocateLike(const PhotometricSolution& band, int width, int height, PhotometricSolution* whole) {
  auto like = [&](const auto& image, auto fill) {
    using Img = std::decay_t<decltype(image)>;
    return image.empty() ? Img() : Img(width, height, image.channels(), fill);
  };
  whole->normal_in_table = like(band.normal_in_table, 0.0f);
  for (size_t i = 0; i < whole->normal_in_table.num_pixels(); ++i) whole->normal_in_table.data()[3 * i + 2] = 1;
  whole->albedo = like(band.albedo, 0.0f);
  whole->status = like(band.status, static_cast<uint8_t>(PixelStatus::kOutsideRegion));
  whole->lights_used = like(band.lights_used, uint8_t{0});
  whole->condition_number = like(band.condition_number, 0.0f);
  whole->residual = like(band.residual, 0.0f);
  whole->solve_path = like(band.solve_path, static_cast<uint8_t>(SolvePath::kNone));
  whole->specular = like(band.specular, 0.0f);
  whole->specular_status = like(band.specular_status, static_cast<uint8_t>(SpecularStatus::kNotSolved));
}

void CopyBandInto(const PhotometricSolution& band, int row0, PhotometricSolution* whole) {
  CopyRowsInto(band.normal_in_table, row0, &whole->normal_in_table);
  CopyRowsInto(band.albedo, row0, &whole->albedo);
  CopyRowsInto(band.status, row0, &whole->status);
  CopyRowsInto(band.lights_used, row0, &whole->lights_used);
  CopyRowsInto(band.condition_number, row0, &whole->condition_number);
  CopyRowsInto(band.residual, row0, &whole->residual);
  CopyRowsInto(band.solve_path, row0, &whole->solve_path);
  CopyRowsInto(band.specular, row0, &whole->specular);
  CopyRowsInto(band.specular_status, row0, &whole->specular_status);
}

// Adds one band's counts to the whole solve's.
void Accumulate(const PhotometricSolverSummary& band, PhotometricSolverSummary* whole) {
  whole->method = band.method;
  whole->bayer_domain = band.bayer_domain;
  whole->kernel_isa = band.kernel_isa;
  whole->num_lights = band.num_lights;
  whole->num_threads = std::max(whole->num_threads, band.num_threads);
  whole->num_pixels += band.num_pixels;
  whole->num_tiles += band.num_tiles;
  whole->tiles_skipped += band.tiles_skipped;
  for (int s = 0; s < kNumPixelStatuses; ++s) whole->pixels_by_status[s] += band.pixels_by_status[s];
  for (int p = 0; p < kNumSolvePaths; ++p) whole->pixels_by_path[p] += band.pixels_by_path[p];
  for (int s = 0; s < kNumSpecularStatuses; ++s) whole->pixels_by_specular[s] += band.pixels_by_specular[s];
  whole->pixels_coherent_lobe += band.pixels_coherent_lobe;
  whole->pixels_coherent_sheen += band.pixels_coherent_sheen;
  whole->pixels_bayer_blended += band.pixels_bayer_blended;
  whole->pixels_bayer_solved += band.pixels_bayer_solved;
  whole->pixels_bayer_lobe += band.pixels_bayer_lobe;
  whole->seconds += band.seconds;
}

// Replaces the developed band's masks by options.sample_masks' and crops the
// band (developed with its margin) to its own `rows` rows from `first`.
void MaskAndCropBand(const BandedSolveOptions& options, int first, int rows, std::vector<DevelopedFrame>* developed,
                     size_t* masked_out) {
  const std::vector<ImageU8> masks = options.sample_masks(RgbInput(*developed));
  if (masks.size() != developed->size()) {
    throw std::invalid_argument("SolveBanded: sample_masks gave " + std::to_string(masks.size()) + " masks for " +
                                std::to_string(developed->size()) + " lights; it must give one per light");
  }
  for (size_t k = 0; k < masks.size(); ++k) {
    DevelopedFrame& frame = (*developed)[k];
    if (!masks[k].SameSize(frame.valid.width(), frame.valid.height()) || masks[k].channels() != 1) {
      throw std::invalid_argument("SolveBanded: sample_masks gave mask " + std::to_string(k) + " of " +
                                  SizeText(masks[k].width(), masks[k].height()) + "; it must be the band's " +
                                  SizeText(frame.valid.width(), frame.valid.height()) + ", 1 channel");
    }
    ImageU8 mask = CropRows(masks[k], first, rows);
    const ImageU8 valid = CropRows(frame.valid, first, rows);
    for (size_t i = 0; i < mask.size(); ++i) *masked_out += valid.data()[i] != 0 && mask.data()[i] == 0;
    frame.rgb = CropRows(frame.rgb, first, rows);
    frame.valid = std::move(mask);
  }
}

// `lobe_mosaics` / `lobe_bayer` (both or neither): the band's mosaics, whose
// shared-lobe pixels are re-solved in the Bayer domain into *lobe_bayer
// (PhotometricSolverInput).
PhotometricSolverSummary SolveRgbBand(const BandedSolveOptions& options, const std::vector<DevelopedFrame>& developed,
                                      const LightField& light_field, int row0, int row1,
                                      PhotometricSolution* band_solution, const ProgressCallback& progress,
                                      const BayerSolverInput* lobe_mosaics = nullptr,
                                      PhotometricSolution* lobe_bayer = nullptr) {
  const LightFieldRows band_field(light_field, row0, row1 - row0);
  PhotometricSolverInput input = RgbInput(developed);
  input.light_field = &band_field;
  input.lobe_mosaics = lobe_mosaics;
  input.lobe_bayer = lobe_bayer;
  return SolvePhotometricStereo(options.solver, input, band_solution, progress);
}

// Solves the developed rows [dev0, dev1) (the band and its margin) in the
// Bayer domain and keeps the band's own rows [row0, row1). The mosaics handed
// to the solver reach one whole tile beyond the band, with only the developed
// rows in its region, so that its tiles are the whole-frame solve's.
PhotometricSolverSummary SolveBayerBand(const PhotometricSolverOptions& solver, const std::vector<DevelopedFrame>& developed,
                                        CfaPattern cfa, const LightField& light_field, int dev0, int dev1, int row0,
                                        int row1, PhotometricSolution* band_solution,
                                        const ProgressCallback& progress) {
  const int tile = solver.tile_size;
  const int solve0 = std::max(0, row0 - tile), solve1 = std::min(light_field.height(), row1 + tile);
  const int width = light_field.width(), solve_rows = solve1 - solve0;
  std::vector<ImageF> mosaics;
  std::vector<ImageU8> valid;
  for (const DevelopedFrame& frame : developed) {
    mosaics.emplace_back(width, solve_rows, 1, 0.0f);
    valid.emplace_back(width, solve_rows, 1, uint8_t{0});
    std::copy(frame.mosaic.data(), frame.mosaic.data() + frame.mosaic.size(), mosaics.back().row(dev0 - solve0));
    std::copy(frame.mosaic_valid.data(), frame.mosaic_valid.data() + frame.mosaic_valid.size(),
              valid.back().row(dev0 - solve0));
  }
  ImageU8 region(width, solve_rows, 1, uint8_t{0});
  std::fill(region.row(dev0 - solve0), region.row(dev0 - solve0) + size_t(dev1 - dev0) * width, uint8_t{1});
  const LightFieldRows solve_field(light_field, solve0, solve_rows);
  BayerSolverInput input;
  for (size_t k = 0; k < mosaics.size(); ++k) {
    input.mosaics.push_back(&mosaics[k]);
    input.sample_valid.push_back(&valid[k]);
  }
  // solve0 is even, so the 2x2 tile's colours are the frame's.
  for (int p = 0; p < 4; ++p) input.cfa_channels[p] = CfaColorAt(cfa, p & 1, p >> 1);
  input.light_field = &solve_field;
  input.region = &region;
  PhotometricSolution with_margin;
  const PhotometricSolverSummary solved = SolvePhotometricStereoBayer(solver, input, &with_margin, progress);
  const int first = row0 - solve0, rows = row1 - row0;
  auto crop = [&](const auto& image) {
    using Img = std::decay_t<decltype(image)>;
    return image.empty() ? Img() : CropRows(image, first, rows);
  };
  band_solution->normal_in_table = crop(with_margin.normal_in_table);
  band_solution->albedo = crop(with_margin.albedo);
  band_solution->status = crop(with_margin.status);
  band_solution->lights_used = crop(with_margin.lights_used);
  band_solution->condition_number = crop(with_margin.condition_number);
  band_solution->residual = crop(with_margin.residual);
  band_solution->solve_path = crop(with_margin.solve_path);
  band_solution->specular = crop(with_margin.specular);
  band_solution->specular_status = crop(with_margin.specular_status);
  // The counts of the band's own rows, not of its margin.
  PhotometricSolverSummary counted = solved;
  counted.num_pixels = band_solution->status.num_pixels();
  counted.pixels_by_status = {};
  counted.pixels_by_path = {};
  counted.pixels_by_specular = {};
  for (size_t i = 0; i < counted.num_pixels; ++i) {
    ++counted.pixels_by_status[band_solution->status.data()[i]];
    ++counted.pixels_by_path[band_solution->solve_path.data()[i]];
    if (!band_solution->specular_status.empty()) ++counted.pixels_by_specular[band_solution->specular_status.data()[i]];
  }
  return counted;
}

// The demosaiced frames of the rows [first, first + rows) of a band developed
// with a margin (the Bayer-domain solve reads the mosaics with theirs).
void CropDevelopedRows(int first, int rows, std::vector<DevelopedFrame>* developed) {
  for (DevelopedFrame& frame : *developed) {
    frame.rgb = CropRows(frame.rgb, first, rows);
    frame.valid = CropRows(frame.valid, first, rows);
  }
}

// The mosaics of the band's rows [row0, row1) from those developed from row
// dev0 on, as a BayerSolverInput without light field or region.
struct BandMosaics {
  BandMosaics(const std::vector<DevelopedFrame>& developed, CfaPattern cfa, int dev0, int row0, int row1) {
    // Developed without margin rows (no sample masks) the mosaics are the band's already.
    const bool cropped = developed.front().mosaic.height() != row1 - row0;
    if (cropped) {
      for (const DevelopedFrame& frame : developed) {
        mosaics.push_back(CropRows(frame.mosaic, row0 - dev0, row1 - row0));
        valid.push_back(CropRows(frame.mosaic_valid, row0 - dev0, row1 - row0));
      }
    }
    for (size_t k = 0; k < developed.size(); ++k) {
      input.mosaics.push_back(cropped ? &mosaics[k] : &developed[k].mosaic);
      input.sample_valid.push_back(cropped ? &valid[k] : &developed[k].mosaic_valid);
    }
    // row0 is even, so the 2x2 tile's colours are the frame's.
    for (int p = 0; p < 4; ++p) input.cfa_channels[p] = CfaColorAt(cfa, p & 1, p >> 1);
  }
  BandMosaics(const BandMosaics&) = delete;
  BandMosaics& operator=(const BandMosaics&) = delete;

  std::vector<ImageF> mosaics;
  std::vector<ImageU8> valid;
  BayerSolverInput input;
};

// The Bayer-domain normals of the band's rows [row0, row1) inside `region`
// (band-sized, the gate's cells), from the band's mosaics. The window is the
// band itself: bands are whole tiles, so its tiles are the whole-frame
// solve's, and without the albedo (not asked for) no pixel reads a
// neighbour, so each pixel in the region is the whole-frame Bayer solve's
// bit for bit.
PhotometricSolverSummary SolveBayerRegion(const PhotometricSolverOptions& solver, const BandMosaics& band,
                                          const LightField& light_field, int row0, int row1,
                                          const ImageU8& region, const ImageU8* sheen_pixels,
                                          PhotometricSolution* bayer, const ProgressCallback& progress) {
  const LightFieldRows band_field(light_field, row0, row1 - row0);
  BayerSolverInput input = band.input;
  input.light_field = &band_field;
  input.region = &region;
  input.sheen_pixels = sheen_pixels;
  return SolvePhotometricStereoBayer(solver, input, bayer, progress);
}

// The band solved on the demosaiced frames, its normals blended with a
// Bayer-domain solve's of the same band (BandedSolveOptions::bayer_blend), which
// runs only on the cells the demosaiced solve says can take a weight
// (SelectBayerBlendCells). `bayer_cost` is the Bayer solve's share of the
// band's solve time expected from the last band (the region's fraction of the
// band: per pixel the two solves cost about the same), for the progress; it
// is updated to this band's.
PhotometricSolverSummary SolveBlendedBand(const BandedSolveOptions& options, std::vector<DevelopedFrame>* developed,
                                          CfaPattern cfa, const LightField& light_field, int dev0, int row0,
                                          int row1, PhotometricSolution* band_solution, BayerNormalBlendSummary* blended,
                                          BayerBlendCellsSummary* cells, double* bayer_cost,
                                          const ProgressCallback& progress) {
  // (Already cropped where sample masks replaced the development's.)
  if (developed->front().rgb.height() != row1 - row0) CropDevelopedRows(row0 - dev0, row1 - row0, developed);
  constexpr double kBlendShare = 0.02;  // choosing the cells and blending: a few passes over the band's maps
  const double rgb_end = (1 - kBlendShare) / (1 + *bayer_cost);
  // The shared lobe's pixels get their Bayer-domain normals in its pass
  // (the Bayer-domain solve below has no lobe).
  const BandMosaics band_mosaics(*developed, cfa, dev0, row0, row1);
  PhotometricSolution lobe_bayer;
  PhotometricSolverSummary summary = SolveRgbBand(options, *developed, light_field, row0, row1, band_solution,
                                                  SubRange(progress, 0, rgb_end), &band_mosaics.input, &lobe_bayer);
  if (!summary.IsUsable()) return summary;
  const auto blend_start = std::chrono::steady_clock::now();
  BayerNormalBlendOptions blend;
  blend.num_threads = options.solver.num_threads;
  blend.gate_ratio = options.bayer_blend_gate_ratio;
  blend.lobe_bayer = &lobe_bayer;
  ImageF band_weights;  // the band's rows of the given weights (bands are whole cells)
  if (options.bayer_blend_weights != nullptr) {
    const int cell = blend.cell_size;
    band_weights = CropRows(*options.bayer_blend_weights, row0 / cell, (row1 - row0 + cell - 1) / cell);
    blend.cell_weights = &band_weights;
  }
  const LightFieldRows band_field(light_field, row0, row1 - row0);
  *cells = SelectBayerBlendCells(blend, *band_solution, band_field);
  const ImageU8 region = BayerBlendRegion(cells->cells, blend.cell_size, light_field.width(), row1 - row0);
  const size_t region_pixels = region.size() - std::count(region.data(), region.data() + region.size(), uint8_t{0});
  *bayer_cost = double(region_pixels) / double(region.size());
  const double blend_seconds = SecondsSince(blend_start);

  // No lobe in the Bayer solve (its pixels keep the demosaiced normal), the
  // per-pixel sheen only when asked: on Lambertian pixels the sheen fit takes
  // noise for sheen and biases the normals the weight then trusts
  // (docs/solver.md). The shared sheen (the default) only on the pixels the
  // demosaiced solve re-solved under one: its groups have the colour to tell
  // a white sheen from shading and shadow, the raw pixels' do not.
  PhotometricSolverOptions bayer_solver = options.solver;
  bayer_solver.adaptive_lobe = false;
  bayer_solver.adaptive_coherent_lobe = false;
  bayer_solver.compute_specular = false;
  bayer_solver.compute_albedo = false;
  bayer_solver.compute_confidence = true;
  PhotometricSolution bayer;
  const PhotometricSolverSummary bayer_summary =
      SolveBayerRegion(bayer_solver, band_mosaics, light_field, row0, row1, region,
                       band_solution->coherent_sheen.empty() ? nullptr : &band_solution->coherent_sheen, &bayer,
                       SubRange(progress, rgb_end, 1 - kBlendShare));
  if (!bayer_summary.IsUsable()) return bayer_summary;
  const auto mix_start = std::chrono::steady_clock::now();
  *blended = BlendBayerNormals(blend, bayer, band_field, band_solution, SubRange(progress, 1 - kBlendShare, 1));
  if (!blended->IsUsable()) {
    summary.termination = blended->termination;
    summary.message = blended->message;
    return summary;
  }
  summary.pixels_bayer_blended = blended->pixels_blended;
  summary.bayer_blend_mean_weight = blended->mean_weight;
  summary.pixels_bayer_solved = region_pixels;
  summary.pixels_bayer_lobe = blended->pixels_lobe_replaced;
  // The band's whole solve.
  summary.seconds += blend_seconds + bayer_summary.seconds + SecondsSince(mix_start);
  return summary;
}

// Rows [row_begin, row_end) of `ahead` (`frame` developed whole with
// `develop`): what DevelopRawRows of those rows gives, the clipped raw
// samples counted in `frame`'s rows as it counts them.
DevelopedFrame DevelopedRows(const DevelopedFrame& ahead, const RawImage& frame, const RawDevelopOptions& develop,
                             int row_begin, int row_end) {
  const int rows = row_end - row_begin;
  DevelopedFrame band;
  band.rgb = CropRows(ahead.rgb, row_begin, rows);
  band.valid = CropRows(ahead.valid, row_begin, rows);
  if (develop.keep_mosaic) {
    band.mosaic = CropRows(ahead.mosaic, row_begin, rows);
    band.mosaic_valid = CropRows(ahead.mosaic_valid, row_begin, rows);
  }
  const int clip_level = static_cast<int>(develop.clip_fraction * frame.white_level);
  for (int y = row_begin; y < row_end; ++y) {
    const uint16_t* raw = frame.mosaic.row(y);
    band.num_clipped_samples += std::count_if(raw, raw + frame.width(), [&](uint16_t v) { return v >= clip_level; });
  }
  return band;
}

void CheckFrames(const RawFrameStack& frames, const LightField& light_field) {
  if (frames.frames.empty() || static_cast<int>(frames.frames.size()) != light_field.num_lights()) {
    throw std::invalid_argument("SolveBanded: " + std::to_string(frames.frames.size()) +
                                " frames for a light field of " + std::to_string(light_field.num_lights()) +
                                " lights; they must be equal and non-zero");
  }
  if (!frames.exposure_scales.empty() && frames.exposure_scales.size() != frames.frames.size()) {
    throw std::invalid_argument("SolveBanded: " + std::to_string(frames.exposure_scales.size()) +
                                " exposure scales for " + std::to_string(frames.frames.size()) +
                                " frames; give one per frame or none");
  }
  for (const RawImage* frame : frames.frames) {
    if (frame == nullptr || !frame->mosaic.SameSize(light_field.width(), light_field.height())) {
      throw std::invalid_argument(
          "SolveBanded: a frame of " +
          (frame ? SizeText(frame->width(), frame->height()) : std::string("null")) + " for a light field of " +
          SizeText(light_field.width(), light_field.height()) + "; every frame must be the light field's size");
    }
  }
  if (!frames.developed.empty() && frames.developed.size() != frames.frames.size()) {
    throw std::invalid_argument("SolveBanded: " + std::to_string(frames.developed.size()) +
                                " frames developed ahead for " + std::to_string(frames.frames.size()) +
                                " frames; give one entry (or null) per frame or none");
  }
  for (const DevelopedFrame* ahead : frames.developed) {
    if (ahead != nullptr && (!ahead->rgb.SameSize(light_field.width(), light_field.height()) ||
                             ahead->rgb.channels() != 3 || !ahead->valid.SameSize(ahead->rgb))) {
      throw std::invalid_argument("SolveBanded: a frame developed ahead of " + ShapeText(ahead->rgb) +
                                  " (valid " + ShapeText(ahead->valid) + ") for a light field of " +
                                  SizeText(light_field.width(), light_field.height()) + "; it must be RGB of its size");
    }
  }
}

// How the frame is cut: bands of whole tiles, lobe blocks and blend cells
// (options.band_rows rounded up to BandRowsUnit), each developed with
// `margin` rows either side when a step reads beyond the band.
struct BandLayout {
  int width = 0, height = 0;
  int band_rows = 0, num_bands = 0;
  int margin = 0;                          // the Bayer-domain demosaic's or sample_masks', rows
  int cell = 0, cell_cols = 0, cell_rows = 0;  // the Bayer blend's cell grid
};

BandLayout LayoutOf(const BandedSolveOptions& options, const LightField& light_field) {
  BandLayout layout;
  layout.width = light_field.width();
  layout.height = light_field.height();
  const int unit = BandRowsUnit(options.solver);
  layout.band_rows = (options.band_rows + unit - 1) / unit * unit;
  layout.num_bands = (layout.height + layout.band_rows - 1) / layout.band_rows;
  // With a mask hook the band is developed with its margin and cropped after the masks.
  // (The blend's Bayer solve has no albedo to demosaic: it needs no margin.)
  layout.margin = std::max(options.bayer_domain ? kBayerMarginRows : 0,
                           options.sample_masks ? options.sample_mask_margin_rows : 0);
  layout.cell = BayerNormalBlendOptions().cell_size;
  layout.cell_cols = (layout.width + layout.cell - 1) / layout.cell;
  layout.cell_rows = (layout.height + layout.cell - 1) / layout.cell;
  return layout;
}

// What the options and the frames developed ahead must hold for this layout.
void CheckBandInputs(const BandedSolveOptions& options, const RawFrameStack& frames, const BandLayout& layout,
                     bool with_mosaic) {
  if (options.bayer_blend_weights != nullptr &&
      !options.bayer_blend_weights->SameSize(layout.cell_cols, layout.cell_rows)) {
    throw std::invalid_argument("SolveBanded: bayer_blend_weights is " +
                                SizeText(options.bayer_blend_weights->width(), options.bayer_blend_weights->height()) +
                                "; it must be the blend's cell grid of " + SizeText(layout.cell_cols, layout.cell_rows));
  }
  for (const DevelopedFrame* ahead : frames.developed) {
    if (ahead != nullptr && with_mosaic && !ahead->mosaic.SameSize(ahead->rgb)) {
      throw std::invalid_argument("SolveBanded: a frame developed ahead without its mosaic (mosaic " +
                                  ShapeText(ahead->mosaic) + "); the Bayer-domain solve needs it");
    }
  }
}

// Rows [dev0, dev1) of every frame, developed (or cut from the frame developed
// ahead) and scaled to the common exposure, into *developed, the frames on up
// to `num_threads` threads; the raw samples at the clip level they count in
// *clipped. `progress` from `begin` to `end` over the frames; false when it
// asked to stop.
bool DevelopBand(int num_threads, const RawFrameStack& frames, const RawDevelopOptions& develop, int dev0, int dev1,
                 const ProgressCallback& progress, double begin, double end, std::vector<DevelopedFrame>* developed,
                 size_t* clipped) {
  const int num_frames = static_cast<int>(frames.frames.size());
  developed->assign(num_frames, DevelopedFrame());
  std::atomic<size_t> clipped_samples{0};
  const bool developed_all = ParallelFor(
      num_frames, ResolveThreadCount(num_threads), 1,
      [&](int first, int last, int) {
        for (int k = first; k < last; ++k) {
          const DevelopedFrame* ahead = frames.developed.empty() ? nullptr : frames.developed[k];
          DevelopedFrame& frame = (*developed)[k];
          frame = ahead ? DevelopedRows(*ahead, *frames.frames[k], develop, dev0, dev1)
                        : DevelopRawRows(*frames.frames[k], frames.dark, develop, dev0, dev1);
          clipped_samples += frame.num_clipped_samples;
          const double scale = frames.exposure_scales.empty() ? 1.0 : frames.exposure_scales[k];
          if (scale != 1) {
            for (ImageF* image : {&frame.rgb, &frame.mosaic}) {
              float* values = image->data();
              for (size_t i = 0; i < image->size(); ++i) values[i] = static_cast<float>(values[i] * scale);
            }
          }
        }
      },
      progress ? std::function<bool(int)>([&](int done) { return progress(begin + (end - begin) * done / num_frames); })
               : std::function<bool(int)>());
  *clipped = clipped_samples.load();
  return developed_all;
}

// The band's own raw samples at the clip level: as the development counted
// them without a margin; with one, from the kept mosaic's per-sample flags
// (0 = at the clip level) of the band's rows [first, first + rows); without a
// mosaic to count them in, none.
size_t ClippedSamplesOfBand(const BandLayout& layout, const RawDevelopOptions& develop,
                            const std::vector<DevelopedFrame>& developed, size_t clipped_in_development, int first,
                            int rows) {
  if (layout.margin == 0) return clipped_in_development;
  if (!develop.keep_mosaic) return 0;
  size_t clipped = 0;
  for (const DevelopedFrame& frame : developed) {
    const uint8_t* flags = frame.mosaic_valid.row(first);
    clipped += std::count(flags, flags + size_t(rows) * layout.width, uint8_t{0});
  }
  return clipped;
}

// The Bayer blend's figures over the bands: each band's cell weights into the
// summary's grid, and the mean weight over every pixel weighed so far.
struct BlendTally {
  double weight_sum = 0;
  size_t pixels_weighed = 0;

  void Add(const BandedSolveOptions& options, const BayerNormalBlendSummary& blended,
           const BayerBlendCellsSummary& cells, int first_cell_row, BandedSolveSummary* summary) {
    if (options.bayer_blend && !blended.cell_weights.empty()) {
      CopyRowsInto(blended.cell_weights, first_cell_row, &summary->bayer_blend_weights);
    }
    weight_sum += blended.mean_weight * double(blended.pixels_weighed);
    // The pixels the gate left out are weighed at 0.
    pixels_weighed += blended.pixels_weighed + (blended.IsUsable() ? cells.pixels_left_out : 0);
    if (pixels_weighed > 0) summary->solver.bayer_blend_mean_weight = weight_sum / pixels_weighed;
  }
};

}  // namespace

void BandedSolveOptions::Check() const {
  solver.Check();
  develop.Check();
  SCANBENCH_REQUIRE_GE_LE("BandedSolveOptions", "band_rows", band_rows, 1, 65536);
  if (bayer_domain && sample_masks) {
    throw std::invalid_argument("BandedSolveOptions: bayer_domain and sample_masks cannot be combined");
  }
  if (bayer_blend && bayer_domain) {
    throw std::invalid_argument("BandedSolveOptions: bayer_blend and bayer_domain cannot be combined");
  }
  SCANBENCH_REQUIRE_GE_LE("BandedSolveOptions", "sample_mask_margin_rows", sample_mask_margin_rows, 0, 64);
  if (bayer_blend_weights != nullptr) {
    if (!bayer_blend) {
      throw std::invalid_argument("BandedSolveOptions: bayer_blend_weights given without bayer_blend");
    }
    BayerNormalBlendOptions blend;
    blend.cell_weights = bayer_blend_weights;
    blend.Check();
  }
  SCANBENCH_REQUIRE_FINITE_GE("BandedSolveOptions", "bayer_blend_gate_ratio", bayer_blend_gate_ratio, 0);
}

PhotometricSolution SolutionRows(const PhotometricSolution& solution, int first, int rows) {
  if (first < 0 || rows < 1 || first + rows > solution.status.height()) {
    throw std::invalid_argument("SolutionRows: rows [" + std::to_string(first) + ", " + std::to_string(first + rows) +
                                ") of a solution of " + std::to_string(solution.status.height()) + " rows");
  }
  auto crop = [&](const auto& image) {
    using Img = std::decay_t<decltype(image)>;
    return image.empty() ? Img() : CropRows(image, first, rows);
  };
  PhotometricSolution band;
  band.normal_in_table = crop(solution.normal_in_table);
  band.albedo = crop(solution.albedo);
  band.status = crop(solution.status);
  band.lights_used = crop(solution.lights_used);
  band.condition_number = crop(solution.condition_number);
  band.residual = crop(solution.residual);
  band.solve_path = crop(solution.solve_path);
  band.specular = crop(solution.specular);
  band.specular_status = crop(solution.specular_status);
  return band;
}

RawDevelopOptions DevelopOptionsFor(const BandedSolveOptions& options) {
  RawDevelopOptions develop = options.develop;
  develop.keep_mosaic = options.bayer_domain || options.bayer_blend;
  return develop;
}

int BandRowsUnit(const PhotometricSolverOptions& solver) {
  return std::lcm(std::lcm(solver.tile_size, CoherentLobeOptions().block_size), BayerNormalBlendOptions().cell_size);
}

std::string BandedSolveSummary::BriefReport() const {
  return "Banded solve: " + std::to_string(num_bands) + " band(s) of " + std::to_string(band_rows) +
         " rows, develop " + Fixed(develop_seconds, 2) + " s, solve " + Fixed(solve_seconds, 2) + " s; " +
         solver.BriefReport();
}

BandedSolveSummary SolveBanded(const BandedSolveOptions& options, const RawFrameStack& frames,
                               const LightField& light_field, PhotometricSolution* solution,
                               const ProgressCallback& progress) {
  if (solution == nullptr) throw std::invalid_argument("SolveBanded: solution must not be null");
  *solution = PhotometricSolution();
  const int width = light_field.width(), height = light_field.height();
  return SolveBanded(
      options, frames, light_field,
      [&](int row0, PhotometricSolution& band) {
        if (row0 == 0) AllocateLike(band, width, height, solution);
        CopyBandInto(band, row0, solution);
      },
      progress);
}

BandedSolveSummary SolveBanded(const BandedSolveOptions& options, const RawFrameStack& frames,
                               const LightField& light_field, const SolvedBandSink& sink,
                               const ProgressCallback& progress) {
  options.Check();
  if (!sink) throw std::invalid_argument("SolveBanded: the band sink must not be empty");
  CheckFrames(frames, light_field);
  const BandLayout layout = LayoutOf(options, light_field);
  const RawDevelopOptions develop = DevelopOptionsFor(options);
  CheckBandInputs(options, frames, layout, develop.keep_mosaic);

  BandedSolveSummary summary;
  summary.band_rows = layout.band_rows;
  if (options.bayer_blend) summary.bayer_blend_weights = ImageF(layout.cell_cols, layout.cell_rows, 1);
  summary.solver.num_lights = static_cast<int>(frames.frames.size());
  BlendTally blend_tally;
  double bayer_cost = 1;  // the Bayer solve's time per band against the demosaiced one's, as last measured
  // Development is cheap beside the solve: a fifth of each band's progress.
  constexpr double kDevelopShare = 0.2;
  for (int band = 0; band < layout.num_bands; ++band) {
    const int row0 = band * layout.band_rows, row1 = std::min(layout.height, row0 + layout.band_rows);
    const double band_begin = double(band) / layout.num_bands, band_end = double(band + 1) / layout.num_bands;
    const double develop_end = band_begin + kDevelopShare * (band_end - band_begin);
    const int dev0 = std::max(0, row0 - layout.margin), dev1 = std::min(layout.height, row1 + layout.margin);

    const auto develop_start = std::chrono::steady_clock::now();
    std::vector<DevelopedFrame> developed;
    size_t clipped = 0;
    const bool developed_all = DevelopBand(options.solver.num_threads, frames, develop, dev0, dev1, progress,
                                           band_begin, develop_end, &developed, &clipped);
    summary.develop_seconds += SecondsSince(develop_start);
    if (!developed_all) {
      summary.SetCancelled("cancelled developing band " + std::to_string(band + 1) + " of " +
                           std::to_string(layout.num_bands));
      summary.solver.SetCancelled(summary.message);  // as a cancel in a band's solve (the depth re-solves read it)
      return summary;
    }
    summary.clipped_samples += ClippedSamplesOfBand(layout, develop, developed, clipped, row0 - dev0, row1 - row0);
    if (options.sample_masks) MaskAndCropBand(options, row0 - dev0, row1 - row0, &developed, &summary.samples_masked_out);

    const auto solve_start = std::chrono::steady_clock::now();
    PhotometricSolution band_solution;
    BayerNormalBlendSummary blended;
    BayerBlendCellsSummary cells;
    const PhotometricSolverSummary solved =
        options.bayer_blend
            ? SolveBlendedBand(options, &developed, frames.frames[0]->cfa, light_field, dev0, row0, row1,
                               &band_solution, &blended, &cells, &bayer_cost,
                               SubRange(progress, develop_end, band_end))
        : options.bayer_domain
            ? SolveBayerBand(options.solver, developed, frames.frames[0]->cfa, light_field, dev0, dev1, row0, row1,
                             &band_solution, SubRange(progress, develop_end, band_end))
            : SolveRgbBand(options, developed, light_field, row0, row1, &band_solution,
                           SubRange(progress, develop_end, band_end));
    Accumulate(solved, &summary.solver);
    blend_tally.Add(options, blended, cells, row0 / layout.cell, &summary);
    summary.solve_seconds += SecondsSince(solve_start);
    sink(row0, band_solution);  // its time is the sink's, not the solve's
    ++summary.num_bands;
    if (!solved.IsUsable()) {
      summary.solver.termination = solved.termination;
      summary.solver.message = solved.message;
      summary.termination = solved.termination;
      summary.message =
          "band " + std::to_string(band + 1) + " of " + std::to_string(layout.num_bands) + ": " + solved.message;
      return summary;
    }
  }
  summary.solver.termination = Termination::kSuccess;
  summary.termination = Termination::kSuccess;
  return summary;
}

}  // namespace scanbench
