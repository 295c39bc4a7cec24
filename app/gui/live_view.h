// The live view's picture: the camera's preview with clipped pixels painted
// red and a histogram drawn under it. Where the bench can give the RAW data
// behind a preview (the simulated camera), clipping is marked where a raw
// sample reaches the clip level the solve uses (RawDevelopOptions::
// clip_fraction of the white level); otherwise (a DSLR's JPEG live view) the
// preview is all there is, and clipping is judged on it per channel. Plain
// functions, no widgets: they run on a worker thread.
#pragma once

#include <QImage>
#include <QString>
#include <cstdint>
#include <vector>

#include "calibration/raw_image.h"

namespace scanbench {

struct LiveFrame {
  QImage image;                 // preview + histogram; null when nothing was fetched
  bool from_raw = false;        // clipping judged on the RAW data (else on the 8-bit preview)
  double clipped_fraction = 0;  // of the preview's pixels, [0, 1]
  QString error;                // why there is no image (the camera's message)
};

// The live view's development of a RAW frame, which the Capture page's
// thumbnails use too (one helper): every 2x2 Bayer tile of a step x step
// block averaged (a box filter: no aliasing on the weave), white-balanced
// (grey world) and scaled so that the 99th percentile of green sits at 90 %;
// a pixel with a raw sample at or above clip_fraction x white level red.
// `min_signal` (fraction of the raw range above black, 0 = none) caps that
// gain: a frame darker than it (the dark frame) is not brightened further.
struct DevelopedRawPreview {
  QImage image;                 // null for an empty frame
  double clipped_fraction = 0;  // of the image's pixels
  std::vector<int> bins;        // 256: each pixel's brightest raw sample over [0, white level]
  int first_hot_bin = 0;        // the bin of the clip level
};
DevelopedRawPreview DevelopRawPreview(const RawImage& raw, double clip_fraction, int max_width,
                                      double min_signal = 0);

// From a RAW frame: DevelopRawPreview; 2x2 Bayer tiles averaged to RGB and reduced to at most
// `max_width` pixels; a pixel is clipped when any raw sample it covers is at
// or above clip_fraction x white level. Shown white-balanced (grey world) and
// scaled so that the 99th percentile of green sits at 90 %. The histogram is
// of each pixel's brightest raw sample over [0, white level] (linear); bins at
// or above the clip level are red.
LiveFrame LiveFrameFromRaw(const RawImage& raw, double clip_fraction, int max_width = 640);

// From an encoded preview (JPEG, PPM) alone: white-balanced (grey world) for
// display, a pixel clipped when any channel is at or above `clip_code` (the
// top of the 8-bit range: a JPEG carries no clip level of the sensor). The
// histogram is of the preview's luminance.
LiveFrame LiveFrameFromPreview(const std::vector<uint8_t>& bytes, int clip_code = 254);

}  // namespace scanbench
