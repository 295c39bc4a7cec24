// From a RAW Bayer mosaic to a linear RGB image the solver can use.
#pragma once

#include "calibration/raw_image.h"
#include "core/image.h"

namespace scanbench {

struct RawDevelopOptions {
  enum class Demosaic {
    kBilinear,   // OpenCV's bilinear Bayer interpolation
    kEdgeAware,  // OpenCV's edge-aware interpolation (less zipper at thread edges)
  };
  Demosaic demosaic = Demosaic::kEdgeAware;
  // Also fill DevelopedFrame::mosaic and mosaic_valid (the Bayer-domain
  // solve's input, issue #13); off: they stay empty.
  bool keep_mosaic = false;
  // A raw sample at or above this fraction of white_level counts as clipped, (0, 1].
  double clip_fraction = 0.98;

  void Check() const;
};

struct DevelopedFrame {
  // Linear RGB, 3 channels: (raw - dark) / (white - black) per raw colour
  // channel. No white balance: the light intensities carry it.
  ImageF rgb;
  // 1 channel: 0 where a raw sample that feeds the pixel was clipped.
  ImageU8 valid;
  size_t num_clipped_samples = 0;  // raw samples at or above the clip level
  // With RawDevelopOptions::keep_mosaic, 1 channel each: every raw sample as
  // rgb's channel of its CFA colour would be before demosaicing ((raw - dark)
  // / (white - black)), and 0 where that one sample was clipped.
  ImageF mosaic;
  ImageU8 mosaic_valid;
};

// Subtracts `dark` (same size and pattern; its black level is then part of
// it) or, when `dark` is null, the frame's own black level. Throws
// std::invalid_argument when the frames do not fit together.
DevelopedFrame DevelopRaw(const RawImage& frame, const RawImage* dark, const RawDevelopOptions& options);

// Rows beyond a band that its development reads (the demosaic's and the clip
// dilation's reach, with room to spare; even, so that the CFA phase holds).
inline constexpr int kDevelopMarginRows = 8;

// Rows [row_begin, row_end) of DevelopRaw(frame, dark, options), bit for bit,
// developed from those rows and kDevelopMarginRows either side only: the
// result is (row_end - row_begin) rows high, and num_clipped_samples counts
// the raw samples of those rows. Throws std::invalid_argument as DevelopRaw,
// and on a range outside [0, height) or an empty one.
DevelopedFrame DevelopRawRows(const RawImage& frame, const RawImage* dark, const RawDevelopOptions& options,
                              int row_begin, int row_end);

}  // namespace scanbench
