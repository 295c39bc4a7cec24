// Internal: a quick look at a Bayer mosaic, for the cameras that have no live
// view of their own (simulated, replay).
#pragma once

#include <cstdint>
#include <vector>

#include "calibration/raw_image.h"

namespace scanbench {

// A binary PPM (P6) at most `max_width` pixels wide: 2x2 CFA tiles averaged to
// RGB, black subtracted, brightened so that the 99th percentile of green sits
// near white (a single LED's frame is dim), gamma 2.2. No white balance.
std::vector<uint8_t> EncodePreviewPpm(const RawImage& raw, int max_width = 640);

}  // namespace scanbench
