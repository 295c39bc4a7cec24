#include "app/io/status_codes.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "solver/photometric_solver.h"

namespace scanbench {

namespace {

constexpr int Code(PixelStatus status) { return static_cast<int>(status); }

// Solved in two greens (the specular lobe only changes the shade); the
// failures in colours far from green and from each other; outside the region
// near-black, as the background it is.
constexpr std::array<StatusCodeInfo, kNumStatusPngCodes> kCodes = {{
    {Code(PixelStatus::kSolved), "solved", "normal, albedo and (where the solve estimates one) the specular lobe solved",
     true, 40, 170, 70},
    {Code(PixelStatus::kOutsideRegion), "outside the region", "not asked for: outside the solve's region", false, 30,
     30, 30},
    {Code(PixelStatus::kTooFewLights), "too few lights", "fewer usable samples than the solve needs (shadow, clipping)",
     false, 230, 160, 30},
    {Code(PixelStatus::kIllConditioned), "ill-conditioned", "the lights used are too close to each other to tell the normal",
     false, 200, 60, 200},
    {Code(PixelStatus::kNoSignal), "no signal", "black or unlit: the scaled normal is too short", false, 60, 90, 200},
    {Code(PixelStatus::kFacingAway), "facing away", "the solved normal points away from the camera", false, 220, 40, 40},
    {Code(PixelStatus::kInvalidInput), "invalid input", "a non-finite sample value", false, 255, 255, 255},
    {kStatusSolvedSpecularUnsupported, "solved, no specular lobe",
     "normal and albedo solved; the samples do not support a specular lobe (specular.exr holds 0 there)", true, 130,
     205, 110},
}};

static_assert(kCodes[Code(PixelStatus::kInvalidInput)].code == Code(PixelStatus::kInvalidInput));
static_assert(kCodes[kStatusSolvedSpecularUnsupported].code == kStatusSolvedSpecularUnsupported);
static_assert(kNumPixelStatuses + 1 == kNumStatusPngCodes, "a new PixelStatus needs its row here");

}  // namespace

const std::array<StatusCodeInfo, kNumStatusPngCodes>& StatusCodes() { return kCodes; }

const StatusCodeInfo& StatusCodeOf(int code) {
  return kCodes[code >= 0 && code < kNumStatusPngCodes ? code : Code(PixelStatus::kInvalidInput)];
}

size_t StatusCounts::solved() const {
  size_t count = 0;
  for (const StatusCodeInfo& info : kCodes) count += info.solved ? pixels[info.code] : 0;
  return count;
}

size_t StatusCounts::in_region() const { return total - pixels[Code(PixelStatus::kOutsideRegion)]; }

double StatusCounts::SolvedFraction() const {
  return in_region() == 0 ? 1.0 : double(solved()) / double(in_region());
}

std::string FlooredPercentText(size_t solved, size_t of) {
  if (of == 0 || solved >= of) return "100 %";
  // Floored to one decimal: 99.97 % reads 99.9 %, not a 100 % that hides a failure.
  const double tenths = std::floor(1000.0 * double(solved) / double(of));
  char text[32];
  std::snprintf(text, sizeof text, "%.1f %%", tenths / 10);
  return text;
}

std::string StatusCounts::Headline() const {
  const size_t region = in_region(), ok = solved();
  std::string line = FlooredPercentText(ok, region) + " solved (" + std::to_string(ok) + " of " +
                     std::to_string(region) + " px in the region)";
  if (ok < region) {
    line += "; " + std::to_string(region - ok) + " px unsolved:";
    bool first = true;
    for (const StatusCodeInfo& info : kCodes) {
      if (info.solved || info.code == Code(PixelStatus::kOutsideRegion) || pixels[info.code] == 0) continue;
      line += std::string(first ? " " : ", ") + std::to_string(pixels[info.code]) + " " + info.name;
      first = false;
    }
  }
  return line;
}

StatusCounts CountStatusCodes(const ImageU8& status) {
  StatusCounts counts;
  for (int y = 0; y < status.height(); ++y) {
    const uint8_t* row = status.row(y);
    for (int x = 0; x < status.width(); ++x) ++counts.pixels[StatusCodeOf(row[x * status.channels()]).code];
  }
  counts.total = size_t(status.width()) * status.height();
  return counts;
}

}  // namespace scanbench
