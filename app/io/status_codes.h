// status.png's codes for the people who look at them: what each code means,
// whether its pixel counts as solved, and the one colour every view of the
// map (the GUI's Results page and its legend) shows it in. The codes are
// PixelStatus (solver/photometric_solver.h) 0 .. 6 and
// kStatusSolvedSpecularUnsupported (app/io/result_maps.h) 7; status.png
// itself stores the codes, not the colours.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "app/io/result_maps.h"
#include "core/image.h"

namespace scanbench {

inline constexpr int kNumStatusPngCodes = kStatusSolvedSpecularUnsupported + 1;

struct StatusCodeInfo {
  uint8_t code = 0;
  const char* name = "";     // "solved", "solved, no specular lobe", "too few lights"
  const char* meaning = "";  // one sentence for a tooltip
  bool solved = false;       // normal and albedo are solved (codes 0 and 7)
  uint8_t r = 0, g = 0, b = 0;  // display colour: the solved codes in greens, the others apart from them
};

// Every code 0 .. kNumStatusPngCodes - 1, in code order.
const std::array<StatusCodeInfo, kNumStatusPngCodes>& StatusCodes();
// The entry of `code`; a code beyond the table (never written) reads as invalid input.
const StatusCodeInfo& StatusCodeOf(int code);

// Pixels per code of a status.png (one channel); codes beyond the table are
// counted as invalid input.
struct StatusCounts {
  std::array<size_t, kNumStatusPngCodes> pixels{};
  size_t total = 0;
  size_t solved() const;     // codes with StatusCodeInfo::solved
  size_t in_region() const;  // every code but outside-the-region
  // Solved share of the region, [0, 1]; 1 for an empty region.
  double SolvedFraction() const;
  // "100 % solved (76800 of 76800 px in the region)"; "99.2 % solved (…); 600 px unsolved: 400 too few lights, 200 no signal".
  std::string Headline() const;
};
StatusCounts CountStatusCodes(const ImageU8& status);

// A share as the headline writes it: "100 %" only when every pixel is
// counted, otherwise at most "99.9 %" (never rounded up to 100), one decimal.
std::string FlooredPercentText(size_t solved, size_t of);

}  // namespace scanbench
