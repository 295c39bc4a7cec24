#include "calibration/raw_develop.h"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/field_error.h"

namespace scanbench {
namespace {

// OpenCV names Bayer layouts after the second row's second and third pixels,
// so a sensor whose top-left tile reads R G / G B is OpenCV's "BayerBG".
int OpenCvBayerCode(CfaPattern pattern, RawDevelopOptions::Demosaic demosaic) {
  const bool edge_aware = demosaic == RawDevelopOptions::Demosaic::kEdgeAware;
  switch (pattern) {
    case CfaPattern::kRGGB: return edge_aware ? cv::COLOR_BayerBG2RGB_EA : cv::COLOR_BayerBG2RGB;
    case CfaPattern::kBGGR: return edge_aware ? cv::COLOR_BayerRG2RGB_EA : cv::COLOR_BayerRG2RGB;
    case CfaPattern::kGRBG: return edge_aware ? cv::COLOR_BayerGB2RGB_EA : cv::COLOR_BayerGB2RGB;
    case CfaPattern::kGBRG: return edge_aware ? cv::COLOR_BayerGR2RGB_EA : cv::COLOR_BayerGR2RGB;
  }
  throw std::invalid_argument("unknown CFA pattern");
}

// Dark-subtracted raw values are shifted up into 16-bit for OpenCV's demosaic
// (it takes 8U/16U only; both interpolations are shift-invariant), so that
// noise below the dark level survives. A 16-bit sensor leaves no headroom.
int DemosaicOffset(uint16_t white_level) { return std::min(16384, 65535 - int(white_level)); }

}  // namespace

void RawDevelopOptions::Check() const {
  SCANBENCH_REQUIRE_GT_LE("RawDevelopOptions", "clip_fraction", clip_fraction, 0, 1);
}

DevelopedFrame DevelopRaw(const RawImage& frame, const RawImage* dark, const RawDevelopOptions& options) {
  return DevelopRawRows(frame, dark, options, 0, frame.height());
}

DevelopedFrame DevelopRawRows(const RawImage& frame, const RawImage* dark, const RawDevelopOptions& options,
                              int row_begin, int row_end) {
  options.Check();
  const int width = frame.width();
  const int height = frame.height();
  if (width < 2 || height < 2 || frame.mosaic.channels() != 1) {
    throw std::invalid_argument("raw frame " + std::to_string(width) + "x" + std::to_string(height) +
                                " must be a 1-channel mosaic of at least 2x2");
  }
  for (int i = 0; i < 4; ++i) {
    if (frame.white_level <= frame.black_level[i]) {
      throw std::invalid_argument("raw frame: white level " + std::to_string(frame.white_level) +
                                  " must exceed black level " + std::to_string(frame.black_level[i]));
    }
  }
  if (dark != nullptr) {
    if (!dark->mosaic.SameSize(frame.mosaic) || dark->cfa != frame.cfa) {
      throw std::invalid_argument("dark frame " + std::to_string(dark->width()) + "x" +
                                  std::to_string(dark->height()) + " " + CfaPatternName(dark->cfa) +
                                  " does not match the frame " + std::to_string(width) + "x" +
                                  std::to_string(height) + " " + CfaPatternName(frame.cfa));
    }
  }

  if (!(row_begin >= 0 && row_begin < row_end && row_end <= height)) {
    throw std::invalid_argument("raw frame rows [" + std::to_string(row_begin) + ", " + std::to_string(row_end) +
                                ") must be a non-empty range inside [0, " + std::to_string(height) + ")");
  }
  // The rows read: the band and its margin, starting on an even row so that
  // the window's CFA pattern is the frame's.
  const int read_begin = std::max(0, row_begin - kDevelopMarginRows) & ~1;
  const int read_end = std::min(height, row_end + kDevelopMarginRows);
  const int read_rows = read_end - read_begin;

  DevelopedFrame developed;
  const int offset = DemosaicOffset(frame.white_level);
  // Normalising range per colour; the two green sites may differ in black.
  std::array<float, 3> range{}, sites{};
  for (int position = 0; position < 4; ++position) {
    const int colour = CfaColorAt(frame.cfa, position & 1, position >> 1);
    range[colour] += float(frame.white_level) - frame.black_level[position];
    sites[colour] += 1;
  }
  for (int c = 0; c < 3; ++c) range[c] /= sites[c];
  const int clip_level = static_cast<int>(options.clip_fraction * frame.white_level);
  cv::Mat shifted(read_rows, width, CV_16UC1);
  cv::Mat clipped(read_rows, width, CV_8UC1, cv::Scalar(0));
  // The kept mosaic's divisor of each pixel of an even and of an odd row (the
  // CFA repeats every 2x2), so that its rows divide as one vector loop.
  std::array<std::vector<float>, 2> mosaic_divisor;
  if (options.keep_mosaic) {
    developed.mosaic = ImageF(width, row_end - row_begin, 1);
    developed.mosaic_valid = ImageU8(width, row_end - row_begin, 1);
    for (int parity = 0; parity < 2; ++parity) {
      mosaic_divisor[parity].resize(width);
      for (int x = 0; x < width; ++x) mosaic_divisor[parity][x] = range[CfaColorAt(frame.cfa, x, parity)];
    }
  }
  for (int y = read_begin; y < read_end; ++y) {
    const uint16_t* raw = frame.mosaic.row(y);
    const uint16_t* dark_row = dark != nullptr ? dark->mosaic.row(y) : nullptr;
    uint16_t* out = shifted.ptr<uint16_t>(y - read_begin);
    uint8_t* clip = clipped.ptr<uint8_t>(y - read_begin);
    const bool counted = y >= row_begin && y < row_end;
    for (int x = 0; x < width; ++x) {
      const int reference = dark_row != nullptr ? dark_row[x] : frame.BlackAt(x, y);
      out[x] = static_cast<uint16_t>(std::clamp(int(raw[x]) - reference + offset, 0, 65535));
      if (raw[x] >= clip_level) {
        clip[x] = 1;
        developed.num_clipped_samples += counted;
      }
    }
    if (options.keep_mosaic && counted) {
      // The same per-sample expression as the demosaic's input above, its own
      // loops (a division per sample, vectorised).
      float* mosaic = developed.mosaic.row(y - row_begin);
      uint8_t* mosaic_valid = developed.mosaic_valid.row(y - row_begin);
      const float* divisor = mosaic_divisor[y & 1].data();
      if (dark_row != nullptr) {
        for (int x = 0; x < width; ++x) mosaic[x] = float(int(raw[x]) - int(dark_row[x])) / divisor[x];
      } else {
        for (int x = 0; x < width; ++x) mosaic[x] = float(int(raw[x]) - int(frame.BlackAt(x, y))) / divisor[x];
      }
      for (int x = 0; x < width; ++x) mosaic_valid[x] = raw[x] >= clip_level ? 0 : 1;
    }
  }

  cv::Mat rgb16;
  cv::cvtColor(shifted, rgb16, OpenCvBayerCode(frame.cfa, options.demosaic));
  // A developed pixel reads raw samples up to one pixel away.
  cv::Mat clipped_near;
  cv::dilate(clipped, clipped_near, cv::Mat::ones(3, 3, CV_8UC1));

  const int rows = row_end - row_begin;
  developed.rgb = ImageF(width, rows, 3);
  developed.valid = ImageU8(width, rows, 1);
  for (int y = 0; y < rows; ++y) {
    const uint16_t* in = rgb16.ptr<uint16_t>(y + row_begin - read_begin);
    const uint8_t* clip = clipped_near.ptr<uint8_t>(y + row_begin - read_begin);
    float* out = developed.rgb.row(y);
    uint8_t* valid = developed.valid.row(y);
    for (int x = 0; x < width; ++x) {
      for (int c = 0; c < 3; ++c) out[3 * x + c] = (float(in[3 * x + c]) - offset) / range[c];
      valid[x] = clip[x] ? 0 : 1;
    }
  }
  return developed;
}

}  // namespace scanbench
