#include "maps/height_from_normals.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"

namespace scanbench {
namespace {

constexpr const char* kWhere = "HeightFromNormalsOptions";

// Both methods minimise sum over edges w * (h_b - h_a - d_ab)^2 between
// 4-neighbours a -> b (to the right, one row down). d_ab is the trapezoidal
// mean of the two pixels' height steps, so a quadratic surface is integrated
// exactly. An edge between two valid pixels has weight 1; an edge touching an
// invalid pixel asks for zero slope with a small weight: holes become a
// membrane (harmonic) fill that barely pulls on the valid pixels around them.
constexpr float kFillWeight = 1e-3f;
enum EdgeKind : uint8_t { kNoEdge = 0, kFillEdge = 1, kSlopeEdge = 2 };
constexpr float kEdgeWeight[3] = {0.0f, kFillWeight, 1.0f};

// One resolution level. Edge data and heights are stored with a one-pixel
// border of ghost cells (no edges to them) so that the relaxation sweep needs
// no bounds checks.
struct Level {
  int width = 0, height = 0;      // pixels of this level
  int stride = 0;                 // width + 2
  double pitch_mm = 0;            // pixel pitch of this level on the sample, mm
  std::vector<uint8_t> valid;     // per pixel, width * height
  // Padded (stride x (height + 2)); edge (x, y) -> (x + 1, y) and (x, y) -> (x, y + 1).
  std::vector<float> target_right, target_down;  // wanted height difference along the edge, mm
  std::vector<uint8_t> kind_right, kind_down;    // EdgeKind
  std::vector<uint8_t> interior_row;             // per row: every edge of its inner pixels is a slope edge

  size_t Padded(int x, int y) const { return static_cast<size_t>(y + 1) * stride + (x + 1); }
  size_t num_pixels() const { return static_cast<size_t>(width) * height; }
};

// Per-pixel height steps of the full level, mm, until the edges are built
// from them (the DCT also fills its holes and builds its right-hand side).
struct SlopeSteps {
  std::vector<float> right;  // height step to the right
  std::vector<float> down;   // ... and one row down
};

void BuildEdges(const SlopeSteps& steps, Level* level) {
  const int w = level->width, h = level->height;
  level->stride = w + 2;
  const size_t padded = static_cast<size_t>(level->stride) * (h + 2);
  level->target_right.assign(padded, 0.0f);
  level->target_down.assign(padded, 0.0f);
  level->kind_right.assign(padded, kNoEdge);
  level->kind_down.assign(padded, kNoEdge);
  // Each row writes only its own pixels' edges: rows in parallel.
  ParallelRows(h, 0, {}, 0, 1, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const size_t p = level->Padded(x, y);
      if (x + 1 < w) {
        const bool both = level->valid[i] && level->valid[i + 1];
        level->kind_right[p] = both ? kSlopeEdge : kFillEdge;
        if (both) level->target_right[p] = 0.5f * (steps.right[i] + steps.right[i + 1]);
      }
      if (y + 1 < h) {
        const bool both = level->valid[i] && level->valid[i + w];
        level->kind_down[p] = both ? kSlopeEdge : kFillEdge;
        if (both) level->target_down[p] = 0.5f * (steps.down[i] + steps.down[i + w]);
      }
    }
  });
}

// Rows whose inner pixels (all but the first and last) have four slope
// edges: the sweep takes a fast path there with no weights to look up.
void MarkInteriorRows(Level* level) {
  const int w = level->width, h = level->height;
  level->interior_row.assign(h, 0);
  if (w < 3) return;
  for (int y = 1; y + 1 < h; ++y) {
    bool interior = true;
    for (int x = 0; x < w && interior; ++x) {
      const size_t p = level->Padded(x, y);
      interior = level->kind_down[p] == kSlopeEdge && level->kind_down[p - level->stride] == kSlopeEdge &&
                 (x + 1 == w || level->kind_right[p] == kSlopeEdge);
    }
    level->interior_row[y] = interior;
  }
}

// Half resolution (odd sizes round up). A coarse pixel stands for the mean
// height of its block, so a coarse edge target is the difference of two block
// means written with the fine edge targets between them: for blocks of two,
// 1/2, 1, 1/2 times the three fine edges, averaged over the block's rows
// (columns for edges down). Rows with a missing fine edge are skipped; a
// coarse edge with no complete row becomes a fill edge.
Level Downsample(const Level& fine) {
  Level coarse;
  coarse.width = (fine.width + 1) / 2;
  coarse.height = (fine.height + 1) / 2;
  coarse.pitch_mm = fine.pitch_mm * 2;
  coarse.stride = coarse.width + 2;
  const size_t padded = static_cast<size_t>(coarse.stride) * (coarse.height + 2);
  coarse.valid.assign(coarse.num_pixels(), 0);
  coarse.target_right.assign(padded, 0.0f);
  coarse.target_down.assign(padded, 0.0f);
  coarse.kind_right.assign(padded, kNoEdge);
  coarse.kind_down.assign(padded, kNoEdge);
  for (int y = 0; y < fine.height; ++y) {
    for (int x = 0; x < fine.width; ++x) {
      if (fine.valid[static_cast<size_t>(y) * fine.width + x])
        coarse.valid[static_cast<size_t>(y / 2) * coarse.width + x / 2] = 1;
    }
  }
  // Difference of the means of blocks [a0, a0 + na) and [a0 + na, a0 + na + nb)
  // along a line of fine edges: edge e (from a0 + e to a0 + e + 1) is crossed by
  // min(e + 1, na) * min(na + nb - 1 - e, nb) of the na * nb pairs.
  auto block_difference = [](const float* targets, const uint8_t* kinds, ptrdiff_t step, int na, int nb,
                             float* difference) {
    double sum = 0;
    for (int e = 0; e < na + nb - 1; ++e) {
      if (kinds[e * step] != kSlopeEdge) return false;
      sum += targets[e * step] * static_cast<double>(std::min(e + 1, na) * std::min(na + nb - 1 - e, nb));
    }
    *difference = static_cast<float>(sum / (na * nb));
    return true;
  };
  for (int yc = 0; yc < coarse.height; ++yc) {
    for (int xc = 0; xc < coarse.width; ++xc) {
      const size_t pc = coarse.Padded(xc, yc);
      const int rows = std::min(2, fine.height - 2 * yc), columns = std::min(2, fine.width - 2 * xc);
      if (xc + 1 < coarse.width) {
        const int next_columns = std::min(2, fine.width - 2 * (xc + 1));
        double sum = 0;
        int complete = 0;
        for (int r = 0; r < rows; ++r) {
          const size_t p = fine.Padded(2 * xc, 2 * yc + r);
          float difference = 0;
          if (block_difference(&fine.target_right[p], &fine.kind_right[p], 1, columns, next_columns, &difference)) {
            sum += difference;
            ++complete;
          }
        }
        coarse.kind_right[pc] = complete > 0 ? kSlopeEdge : kFillEdge;
        coarse.target_right[pc] = complete > 0 ? static_cast<float>(sum / complete) : 0.0f;
      }
      if (yc + 1 < coarse.height) {
        const int next_rows = std::min(2, fine.height - 2 * (yc + 1));
        double sum = 0;
        int complete = 0;
        for (int c = 0; c < columns; ++c) {
          const size_t p = fine.Padded(2 * xc + c, 2 * yc);
          float difference = 0;
          if (block_difference(&fine.target_down[p], &fine.kind_down[p], fine.stride, rows, next_rows, &difference)) {
            sum += difference;
            ++complete;
          }
        }
        coarse.kind_down[pc] = complete > 0 ? kSlopeEdge : kFillEdge;
        coarse.target_down[pc] = complete > 0 ? static_cast<float>(sum / complete) : 0.0f;
      }
    }
  }
  MarkInteriorRows(&coarse);
  return coarse;
}

// Bilinear, coarse pixel centre xc sits at fine x = 2 xc + 0.5; heights are
// in mm at every level, so no scaling. Both images padded.
std::vector<float> Upsample(const Level& coarse, const std::vector<float>& coarse_height, const Level& fine) {
  std::vector<float> fine_height(static_cast<size_t>(fine.stride) * (fine.height + 2), 0.0f);
  std::vector<int> x0(fine.width), x1(fine.width);
  std::vector<float> fx(fine.width);
  for (int x = 0; x < fine.width; ++x) {
    const double xc = std::clamp((x - 0.5) / 2.0, 0.0, coarse.width - 1.0);
    x0[x] = static_cast<int>(std::floor(xc));
    x1[x] = std::min(x0[x] + 1, coarse.width - 1);
    fx[x] = static_cast<float>(xc - x0[x]);
  }
  for (int y = 0; y < fine.height; ++y) {
    const double yc = std::clamp((y - 0.5) / 2.0, 0.0, coarse.height - 1.0);
    const int y0 = static_cast<int>(std::floor(yc));
    const int y1 = std::min(y0 + 1, coarse.height - 1);
    const float fy = static_cast<float>(yc - y0);
    const float* row0 = coarse_height.data() + coarse.Padded(0, y0);
    const float* row1 = coarse_height.data() + coarse.Padded(0, y1);
    float* out = fine_height.data() + fine.Padded(0, y);
    for (int x = 0; x < fine.width; ++x) {
      const float top = row0[x0[x]] + fx[x] * (row0[x1[x]] - row0[x0[x]]);
      const float bottom = row1[x0[x]] + fx[x] * (row1[x1[x]] - row1[x0[x]]);
      out[x] = top + fy * (bottom - top);
    }
  }
  return fine_height;
}

// Updates the pixels of one colour ((x + y) % 2 == colour) in rows
// [row_begin, row_end): every pixel moves to the weighted mean of what its
// neighbours and the edge targets say it should be, or over_relaxation times
// as far (SOR). A pixel's neighbours all have the other colour, so rows and
// pixels of one colour are independent. Returns the sum of squared updates.
double RelaxColour(const Level& level, float over_relaxation, int colour, int row_begin, int row_end, float* h) {
  const float* tr = level.target_right.data();
  const float* td = level.target_down.data();
  const uint8_t* kr = level.kind_right.data();
  const uint8_t* kd = level.kind_down.data();
  const ptrdiff_t s = level.stride;
  double sum_squared_update = 0;
  float row_sum = 0;
  auto relax_any = [&](size_t i) {
    const float w_left = kEdgeWeight[kr[i - 1]], w_right = kEdgeWeight[kr[i]];
    const float w_up = kEdgeWeight[kd[i - s]], w_down = kEdgeWeight[kd[i]];
    const float weight = w_left + w_right + w_up + w_down;
    if (weight <= 0) return;  // a 1x1 level
    const float wanted = (w_left * (h[i - 1] + tr[i - 1]) + w_right * (h[i + 1] - tr[i]) +
                          w_up * (h[i - s] + td[i - s]) + w_down * (h[i + s] - td[i])) /
                         weight;
    const float update = over_relaxation * (wanted - h[i]);
    h[i] += update;
    row_sum += update * update;
  };
  for (int y = row_begin; y < row_end; ++y) {
    const size_t begin = level.Padded(0, y);
    const size_t end = begin + static_cast<size_t>(level.width);
    size_t i = begin + ((y + colour) & 1);
    row_sum = 0;
    if (level.interior_row[y]) {
      if (i == begin) {
        relax_any(i);
        i += 2;
      }
      // All four weights 1: bit for bit what relax_any computes, without the lookups.
      for (; i + 1 < end; i += 2) {
        const float wanted =
            ((h[i - 1] + tr[i - 1]) + (h[i + 1] - tr[i]) + (h[i - s] + td[i - s]) + (h[i + s] - td[i])) * 0.25f;
        const float update = over_relaxation * (wanted - h[i]);
        h[i] += update;
        row_sum += update * update;
      }
    }
    for (; i < end; i += 2) relax_any(i);
    sum_squared_update += row_sum;
  }
  return sum_squared_update;
}

// One red-black Gauss-Seidel sweep (both colours). Large levels are split into
// fixed bands of rows run through ParallelFor; the result does not depend on
// the number of threads (bands are fixed, sums added in order).
double GaussSeidelSweep(const Level& level, float over_relaxation, std::vector<float>* height_padded) {
  constexpr size_t kParallelPixels = 1 << 16;
  constexpr int kBandRows = 32;
  float* h = height_padded->data();
  if (level.num_pixels() < kParallelPixels) {
    return RelaxColour(level, over_relaxation, 0, 0, level.height, h) +
           RelaxColour(level, over_relaxation, 1, 0, level.height, h);
  }
  const int bands = (level.height + kBandRows - 1) / kBandRows;
  std::vector<double> band_sums(bands, 0.0);
  double sum_squared_update = 0;
  for (int colour = 0; colour < 2; ++colour) {
    ParallelFor(bands, 0, 1, [&](int first, int last, int) {
      for (int band = first; band < last; ++band) {
        band_sums[band] = RelaxColour(level, over_relaxation, colour, band * kBandRows,
                                      std::min(level.height, (band + 1) * kBandRows), h);
      }
    });
    for (const double band_sum : band_sums) sum_squared_update += band_sum;
  }
  return sum_squared_update;
}

// Pull-push fill of the holes of per-pixel fields: valid-weighted 2x2 means
// going down (weight capped at 1), bilinear going up, blended by the weight,
// so valid pixels keep their values and holes get a smooth extension.
void PullPushFill(int width, int height, std::vector<float> weight, std::vector<std::vector<float>*> fields) {
  if (width <= 1 && height <= 1) return;
  const int cw = (width + 1) / 2, ch = (height + 1) / 2;
  std::vector<float> coarse_weight(static_cast<size_t>(cw) * ch, 0.0f);
  std::vector<std::vector<float>> coarse(fields.size(), std::vector<float>(coarse_weight.size(), 0.0f));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const size_t i = static_cast<size_t>(y) * width + x, ic = static_cast<size_t>(y / 2) * cw + x / 2;
      coarse_weight[ic] += weight[i];
      for (size_t f = 0; f < fields.size(); ++f) coarse[f][ic] += weight[i] * (*fields[f])[i];
    }
  }
  for (size_t ic = 0; ic < coarse_weight.size(); ++ic) {
    for (size_t f = 0; f < fields.size(); ++f)
      coarse[f][ic] = coarse_weight[ic] > 0 ? coarse[f][ic] / coarse_weight[ic] : 0.0f;
    coarse_weight[ic] = std::min(coarse_weight[ic], 1.0f);
  }
  bool complete = true;
  for (const float w : coarse_weight) complete = complete && w >= 1.0f;
  std::vector<std::vector<float>*> coarse_fields;
  for (auto& field : coarse) coarse_fields.push_back(&field);
  if (!complete) PullPushFill(cw, ch, coarse_weight, coarse_fields);
  for (int y = 0; y < height; ++y) {
    const double yc = std::clamp((y - 0.5) / 2.0, 0.0, ch - 1.0);
    const int y0 = static_cast<int>(yc), y1 = std::min(y0 + 1, ch - 1);
    const double fy = yc - y0;
    for (int x = 0; x < width; ++x) {
      const size_t i = static_cast<size_t>(y) * width + x;
      if (weight[i] >= 1.0f) continue;
      const double xc = std::clamp((x - 0.5) / 2.0, 0.0, cw - 1.0);
      const int x0 = static_cast<int>(xc), x1 = std::min(x0 + 1, cw - 1);
      const double fx = xc - x0;
      for (size_t f = 0; f < fields.size(); ++f) {
        const std::vector<float>& c = coarse[f];
        const double top = c[static_cast<size_t>(y0) * cw + x0] * (1 - fx) + c[static_cast<size_t>(y0) * cw + x1] * fx;
        const double bottom =
            c[static_cast<size_t>(y1) * cw + x0] * (1 - fx) + c[static_cast<size_t>(y1) * cw + x1] * fx;
        const double up = top * (1 - fy) + bottom * fy;
        (*fields[f])[i] = static_cast<float>(weight[i] * (*fields[f])[i] + (1 - weight[i]) * up);
      }
    }
  }
}

// Right-hand side of the normal equations L h = b (L the free-boundary graph
// Laplacian, every edge weight 1, trapezoidal targets from the per-pixel
// steps): b = sum of incoming edge targets - sum of outgoing. Each pixel
// gathers its four terms from 0 in the order a row-major scatter over the
// edges adds them (the edge from above, from the left, then its own right and
// down edges), so the rows run in parallel with the scatter's bits.
cv::Mat PoissonRightHandSide(int width, int height, const std::vector<float>& step_right,
                             const std::vector<float>& step_down) {
  cv::Mat rhs(height, width, CV_64F);
  ParallelRows(height, 0, {}, 0, 1, [&](int y) {
    double* out = rhs.ptr<double>(y);
    for (int x = 0; x < width; ++x) {
      const size_t i = static_cast<size_t>(y) * width + x;
      double b = 0;
      if (y > 0) b += 0.5 * (step_down[i - width] + step_down[i]);
      if (x > 0) b += 0.5 * (step_right[i - 1] + step_right[i]);
      if (x + 1 < width) b -= 0.5 * (step_right[i] + step_right[i + 1]);
      if (y + 1 < height) b -= 0.5 * (step_down[i] + step_down[i + width]);
      out[x] = b;
    }
  });
  return rhs;
}

// As PoissonRightHandSide, from the level's edge targets on slope edges and
// the differences of `current` on every other edge.
cv::Mat HoleConsistentRightHandSide(const Level& level, const cv::Mat& current) {
  cv::Mat rhs(level.height, level.width, CV_64F, cv::Scalar(0));
  for (int y = 0; y < level.height; ++y) {
    double* out = rhs.ptr<double>(y);
    const double* h = current.ptr<double>(y);
    for (int x = 0; x < level.width; ++x) {
      const size_t p = level.Padded(x, y);
      if (x + 1 < level.width) {
        const double target = level.kind_right[p] == kSlopeEdge ? level.target_right[p] : h[x + 1] - h[x];
        out[x] -= target;
        out[x + 1] += target;
      }
      if (y + 1 < level.height) {
        const double target =
            level.kind_down[p] == kSlopeEdge ? level.target_down[p] : current.ptr<double>(y + 1)[x] - h[x];
        out[x] -= target;
        rhs.ptr<double>(y + 1)[x] += target;
      }
    }
  }
  return rhs;
}

// Eigenvalues of the free-boundary (Neumann) Laplacian on a size-n path for
// the cosine of frequency k: 2 - 2 cos(pi k / n).
std::vector<double> PathEigenvalues(int n, int period) {
  std::vector<double> values(n);
  for (int k = 0; k < n; ++k) values[k] = 2.0 - 2.0 * std::cos(2.0 * CV_PI * k / period);
  return values;
}

// cv::dct of a matrix (`flags` 0 or cv::DCT_INVERSE) with the rows and then
// the columns split over the pool: cv::dct alone runs on one thread. The
// columns go through the same 1-D transform as rows of a transposed block of
// 64, which is what cv::dct does with a column, so the result is the same
// bits as cv::dct's (checked bit for bit on random 200 x 150 and 4928 x 3264
// matrices, both directions, when this was written; the export's 16 MP maps
// came out identical). Each thread transposes its blocks into two buffers
// of its own, made once: a block is 1.7 MB at 16 MP, above the allocator's
// mmap threshold (core/memory.h), so three new matrices a block were 385 MB
// of fresh pages a transform (a quarter of the export's page faults).
cv::Mat DctOnThePool(const cv::Mat& in, int flags) {
  constexpr int kBand = 64;
  cv::Mat out(in.size(), CV_64F);
  ParallelFor((in.rows + kBand - 1) / kBand, 0, 1, [&](int first, int last, int) {
    for (int band = first; band < last; ++band) {
      const int begin = band * kBand, end = std::min(in.rows, begin + kBand);
      cv::dct(in.rowRange(begin, end), out.rowRange(begin, end), flags | cv::DCT_ROWS);
    }
  });
  const int threads = ResolveThreadCount(0);
  std::vector<cv::Mat> blocks(threads), transformed(threads);  // per worker, reused from block to block
  ParallelFor((in.cols + kBand - 1) / kBand, threads, 1, [&](int first, int last, int worker) {
    cv::Mat& block = blocks[worker];
    cv::Mat& block_out = transformed[worker];
    for (int band = first; band < last; ++band) {
      const int begin = band * kBand, end = std::min(in.cols, begin + kBand);
      cv::transpose(out.colRange(begin, end), block);  // (re)allocates only when the block's shape changes
      cv::dct(block, block_out, flags | cv::DCT_ROWS);
      cv::Mat target = out.colRange(begin, end);
      cv::transpose(block_out, target);  // into the columns themselves: `target` has the shape already
    }
  });
  return out;
}

// Solves L h = rhs with the free-boundary Laplacian, mean zero. Even sizes:
// cv::dct diagonalises it directly. cv::dct has no odd sizes, so those go
// through cv::dft of the mirrored (2w x 2h) extension, which is the same
// cosine basis at four times the memory.
cv::Mat SolveNeumannPoisson(const cv::Mat& rhs) {
  const int w = rhs.cols, h = rhs.rows;
  if (w % 2 == 0 && h % 2 == 0) {
    cv::Mat spectrum = DctOnThePool(rhs, 0);
    const std::vector<double> ex = PathEigenvalues(w, 2 * w), ey = PathEigenvalues(h, 2 * h);
    ParallelRows(h, 0, {}, 0, 1, [&](int y) {
      double* row = spectrum.ptr<double>(y);
      for (int x = 0; x < w; ++x) row[x] = (x == 0 && y == 0) ? 0.0 : row[x] / (ex[x] + ey[y]);
    });
    return DctOnThePool(spectrum, cv::DCT_INVERSE);
  }
  cv::Mat mirrored;
  cv::Mat flipped_x, flipped_y, flipped_xy;
  cv::flip(rhs, flipped_x, 1);
  cv::flip(rhs, flipped_y, 0);
  cv::flip(rhs, flipped_xy, -1);
  cv::Mat top, bottom;
  cv::hconcat(rhs, flipped_x, top);
  cv::hconcat(flipped_y, flipped_xy, bottom);
  cv::vconcat(top, bottom, mirrored);
  cv::Mat spectrum;
  cv::dft(mirrored, spectrum, cv::DFT_COMPLEX_OUTPUT);
  const std::vector<double> ex = PathEigenvalues(2 * w, 2 * w), ey = PathEigenvalues(2 * h, 2 * h);
  for (int y = 0; y < 2 * h; ++y) {
    cv::Vec2d* row = spectrum.ptr<cv::Vec2d>(y);
    for (int x = 0; x < 2 * w; ++x) {
      const double eigenvalue = ex[x] + ey[y];
      row[x] = eigenvalue > 0 ? row[x] / eigenvalue : cv::Vec2d(0, 0);
    }
  }
  cv::Mat solution;
  cv::dft(spectrum, solution, cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
  return solution(cv::Rect(0, 0, w, h)).clone();
}

void CheckInputs(const ImageF& normal_in_tangent, const ImageU8* valid, const ImageF* height_mm) {
  if (normal_in_tangent.empty() || normal_in_tangent.channels() != 3) {
    throw std::invalid_argument("HeightFromNormals: normal_in_tangent is " + std::to_string(normal_in_tangent.width()) +
                                "x" + std::to_string(normal_in_tangent.height()) + "x" +
                                std::to_string(normal_in_tangent.channels()) + ", must be a non-empty 3-channel image");
  }
  if (valid != nullptr && (!valid->SameSize(normal_in_tangent) || valid->channels() != 1)) {
    throw std::invalid_argument(
        "HeightFromNormals: valid mask is " + std::to_string(valid->width()) + "x" + std::to_string(valid->height()) +
        "x" + std::to_string(valid->channels()) + ", must be 1 channel of the normal map's size " +
        std::to_string(normal_in_tangent.width()) + "x" + std::to_string(normal_in_tangent.height()));
  }
  if (height_mm == nullptr) throw std::invalid_argument("HeightFromNormals: height_mm must not be null");
}

// The full level's size, pitch and valid pixels, and its height steps in mm.
// Image rows go down while the tangent y goes up, so the step one row down is
// +n.y / n.z (slope dz/dy_up = -n.y / n.z).
struct FullLevelSlopes {
  Level level;
  SlopeSteps steps;
  size_t valid_count = 0;
  size_t unusable_normals = 0;  // wanted pixels whose normal is non-finite or zero
};

FullLevelSlopes SlopesFromNormals(const ImageF& normal_in_tangent, const ImageU8* valid,
                                  const HeightFromNormalsOptions& options) {
  FullLevelSlopes full;
  Level& level = full.level;
  level.width = normal_in_tangent.width();
  level.height = normal_in_tangent.height();
  level.pitch_mm = options.mm_per_pixel;
  level.valid.assign(level.num_pixels(), 0);
  full.steps.right.assign(level.num_pixels(), 0.0f);
  full.steps.down.assign(level.num_pixels(), 0.0f);
  const double mm = options.mm_per_pixel;
  const float max_slope = static_cast<float>(options.max_slope);
  // Rows in parallel; their counts are added after.
  std::vector<size_t> row_unusable(level.height, 0), row_valid(level.height, 0);
  ParallelRows(level.height, 0, {}, 0, 1, [&](int y) {
    const size_t row_begin = static_cast<size_t>(y) * level.width;
    for (size_t i = row_begin; i < row_begin + level.width; ++i) {
      const float* n = normal_in_tangent.data() + 3 * i;
      const bool wanted = valid == nullptr || valid->data()[i] != 0;
      const bool finite = std::isfinite(n[0]) && std::isfinite(n[1]) && std::isfinite(n[2]);
      const bool usable = finite && n[0] * n[0] + n[1] * n[1] + n[2] * n[2] > 1e-12f;
      if (wanted && !usable) ++row_unusable[y];
      if (!wanted || !usable) continue;
      // Near-grazing or back-facing normals: clamp the slope instead of dividing by ~0.
      const float nz = std::max(n[2], 1e-6f);
      full.steps.right[i] = static_cast<float>(std::clamp(-n[0] / nz, -max_slope, max_slope) * mm);
      full.steps.down[i] = static_cast<float>(std::clamp(n[1] / nz, -max_slope, max_slope) * mm);
      level.valid[i] = 1;
      ++row_valid[y];
    }
  });
  for (int y = 0; y < level.height; ++y) {
    full.unusable_normals += row_unusable[y];
    full.valid_count += row_valid[y];
  }
  return full;
}

// Progress in units of work (pixel sweeps, DCT solves), reported at most
// every 0.1% (thousands of sweeps on tiny coarse levels would otherwise flood
// the caller) and always at the end. Once the callback said no it is never
// asked again.
class WorkProgress {
 public:
  WorkProgress(const ProgressCallback& progress, double total_work) : progress_(progress), total_(total_work) {}

  // Counts `work` as done and reports; false once cancelled.
  bool Advance(double work) {
    if (cancelled_) return false;
    done_ += work;
    const double fraction = std::min(1.0, done_ / total_);
    if (progress_ && (fraction >= last_reported_ + 1e-3 || fraction >= 1.0) && fraction > last_reported_) {
      last_reported_ = fraction;
      if (!progress_(fraction)) cancelled_ = true;
    }
    return !cancelled_;
  }
  // Work budgeted but not needed (a level that converged early), not reported.
  void Skip(double work) { done_ += work; }
  // Reports the end, after levels or rounds that stopped early.
  void Finish() {
    if (!cancelled_) Advance(total_ - done_);
  }
  bool cancelled() const { return cancelled_; }

 private:
  const ProgressCallback& progress_;
  double total_ = 1;
  double done_ = 0;
  double last_reported_ = -1;
  bool cancelled_ = false;
};

// What a method leaves: the full level's heights, padded as the level.
struct MethodResult {
  std::vector<float> height_padded;
  bool cancelled = false;
  int hole_rounds = 0;  // DCT re-solves for the holes
};

// The multi-resolution relaxation: halves the edge targets down to
// coarsest_level_size, relaxes the coarsest level from zero and each finer
// one from the bilinear upsampling of the one below. A cancelled run may stop
// on a coarse level: its estimate is brought to full size.
MethodResult SolveByRelaxation(const HeightFromNormalsOptions& options, const Level& full,
                               const ProgressCallback& progress, HeightFromNormalsSummary* summary) {
  // The longer side decides, so a thin strip still gets its coarse levels (a side of 1 stays 1).
  std::vector<Level> coarse;  // levels 1, 2, ...
  auto level = [&](size_t k) -> const Level& { return k == 0 ? full : coarse[k - 1]; };
  while (std::max((level(coarse.size()).width + 1) / 2, (level(coarse.size()).height + 1) / 2) >=
         options.coarsest_level_size) {
    coarse.push_back(Downsample(level(coarse.size())));
  }
  const size_t num_levels = coarse.size() + 1;
  // Each level is budgeted at its maximum number of sweeps.
  double total_work = 0;
  for (size_t k = 0; k < num_levels; ++k) {
    total_work += static_cast<double>(level(k).num_pixels()) * options.max_sweeps_per_level;
  }
  WorkProgress work(progress, total_work);

  MethodResult result;
  std::vector<float>& solution = result.height_padded;  // of the level `solved_level`
  size_t solved_level = num_levels - 1;
  summary->converged = true;
  for (int k = static_cast<int>(num_levels) - 1; k >= 0 && !work.cancelled(); --k) {
    const Level& current = level(k);
    if (solution.empty()) {
      solution.assign(static_cast<size_t>(current.stride) * (current.height + 2), 0.0f);
    } else if (static_cast<size_t>(k) != solved_level) {
      solution = Upsample(level(solved_level), solution, current);
    }
    solved_level = k;
    ++summary->levels;
    const double threshold = options.tolerance * current.pitch_mm;
    bool level_converged = false;
    int sweeps = 0;
    while (sweeps < options.max_sweeps_per_level) {
      const double squared = GaussSeidelSweep(current, static_cast<float>(options.over_relaxation), &solution);
      ++sweeps;
      const double rms_update = std::sqrt(squared / static_cast<double>(current.num_pixels()));
      if (!work.Advance(static_cast<double>(current.num_pixels()))) break;
      if (rms_update <= threshold) {
        level_converged = true;
        break;
      }
    }
    work.Skip(static_cast<double>(current.num_pixels()) * (options.max_sweeps_per_level - sweeps));
    summary->total_sweeps += sweeps;
    if (!level_converged) summary->converged = false;
  }
  work.Finish();
  for (int k = static_cast<int>(solved_level) - 1; k >= 0; --k) solution = Upsample(level(k + 1), solution, level(k));
  result.cancelled = work.cancelled();
  return result;
}

// The exact least-squares answer by a DCT Poisson solve. The DCT needs a
// slope everywhere: holes get a smooth extension of the slopes around them
// (pull-push), so they neither bend the valid area nor go flat. Then each
// re-solve gives the edges into holes the differences of the current solution
// (an integrable fill), so the valid pixels around the holes follow their own
// slopes more; it stops once a round changes the height by less than the
// tolerance. A cancel before the first solve leaves a flat (zero) height.
MethodResult SolveByDct(const HeightFromNormalsOptions& options, const Level& full, SlopeSteps steps, bool all_valid,
                        const ProgressCallback& progress, HeightFromNormalsSummary* summary) {
  const int width = full.width, height = full.height;
  if (!all_valid) {
    std::vector<float> weight(full.valid.begin(), full.valid.end());
    PullPushFill(width, height, std::move(weight), {&steps.right, &steps.down});
  }
  cv::Mat poisson_rhs = PoissonRightHandSide(width, height, steps.right, steps.down);
  steps = {};
  WorkProgress work(progress, 1.0 + (all_valid ? 0 : options.dct_hole_iterations));

  MethodResult result;
  result.height_padded.assign(static_cast<size_t>(full.stride) * (full.height + 2), 0.0f);
  summary->converged = true;
  if (work.Advance(0.1)) {
    cv::Mat dct_height = SolveNeumannPoisson(poisson_rhs);
    poisson_rhs.release();
    bool holes_settled = false;
    for (int round = 0; !all_valid && round < options.dct_hole_iterations && !work.cancelled(); ++round) {
      cv::Mat next = SolveNeumannPoisson(HoleConsistentRightHandSide(full, dct_height));
      const double rms_change = cv::norm(next, dct_height, cv::NORM_L2) / std::sqrt(static_cast<double>(next.total()));
      dct_height = next;
      ++result.hole_rounds;
      work.Advance(1.0);
      holes_settled = rms_change <= options.tolerance * full.pitch_mm;
      if (holes_settled) break;
    }
    summary->converged = all_valid || holes_settled;
    ParallelRows(height, 0, {}, 0, 1, [&](int y) {
      const double* row = dct_height.ptr<double>(y);
      float* out = result.height_padded.data() + full.Padded(0, y);
      for (int x = 0; x < width; ++x) out[x] = static_cast<float>(row[x]);
    });
    summary->levels = 1;
    work.Advance(0.9);
  }
  work.Finish();
  result.cancelled = work.cancelled();
  return result;
}

// The output: zero mean over the valid pixels. Also the RMS slope residual of
// the fit over the slope edges, unitless.
ImageF CentredHeight(const Level& full, const std::vector<float>& solution, size_t valid_count,
                     double* rms_slope_residual) {
  const int width = full.width, height = full.height;
  const double mm = full.pitch_mm;
  double sum = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if (full.valid[static_cast<size_t>(y) * width + x]) sum += solution[full.Padded(x, y)];
    }
  }
  const float mean = static_cast<float>(sum / static_cast<double>(valid_count));
  ImageF height_mm(width, height, 1);
  double residual_squared = 0;
  size_t slope_edges = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const size_t p = full.Padded(x, y);
      height_mm(x, y) = solution[p] - mean;
      if (full.kind_right[p] == kSlopeEdge) {
        const double r = (solution[p + 1] - solution[p] - full.target_right[p]) / mm;
        residual_squared += r * r;
        ++slope_edges;
      }
      if (full.kind_down[p] == kSlopeEdge) {
        const double r = (solution[p + full.stride] - solution[p] - full.target_down[p]) / mm;
        residual_squared += r * r;
        ++slope_edges;
      }
    }
  }
  *rms_slope_residual = slope_edges > 0 ? std::sqrt(residual_squared / static_cast<double>(slope_edges)) : 0.0;
  return height_mm;
}

std::string Describe(const HeightFromNormalsSummary& summary, bool relaxation, bool cancelled, size_t valid_count,
                     size_t num_pixels, int hole_rounds, size_t unusable_normals) {
  char figures[256];
  std::snprintf(figures, sizeof(figures),
                "%s, %zu of %zu pixels valid, %d level(s), %d sweep(s)%s, RMS slope residual %.3g, %.2f s",
                summary.method.c_str(), valid_count, num_pixels, summary.levels, summary.total_sweeps,
                relaxation ? (summary.converged ? ", converged" : ", not converged") : "",
                summary.rms_slope_residual, summary.seconds);
  std::string message = std::string(cancelled ? "cancelled: " : "") + figures;
  if (hole_rounds > 0) message += "; " + std::to_string(hole_rounds) + " DCT re-solve(s) for the holes";
  if (unusable_normals > 0) {
    message += "; " + std::to_string(unusable_normals) + " pixel(s) with a non-finite or zero normal treated as holes";
  }
  return message;
}

}  // namespace

void HeightFromNormalsOptions::Check() const {
  SCANBENCH_REQUIRE_FINITE_GT(kWhere, "mm_per_pixel", mm_per_pixel, 0);
  SCANBENCH_REQUIRE_GE(kWhere, "max_sweeps_per_level", max_sweeps_per_level, 1);
  SCANBENCH_REQUIRE_FINITE_GE(kWhere, "tolerance", tolerance, 0);
  SCANBENCH_REQUIRE_GE(kWhere, "coarsest_level_size", coarsest_level_size, 2);
  SCANBENCH_REQUIRE_FINITE_GT(kWhere, "max_slope", max_slope, 0);
  SCANBENCH_REQUIRE_GT_LT(kWhere, "over_relaxation", over_relaxation, 0, 2);
  SCANBENCH_REQUIRE_GE(kWhere, "dct_hole_iterations", dct_hole_iterations, 0);
  if (method != Method::kMultiresolutionRelaxation && method != Method::kDctPoisson) {
    throw FieldError(kWhere, "method", static_cast<int>(method), "must be relaxation or dct");
  }
}

const char* HeightMethodName(HeightFromNormalsOptions::Method method) {
  switch (method) {
    case HeightFromNormalsOptions::Method::kMultiresolutionRelaxation:
      return "relaxation";
    case HeightFromNormalsOptions::Method::kDctPoisson:
      return "dct";
  }
  return "unknown";
}

HeightFromNormalsOptions::Method HeightMethodFromName(const std::string& name) {
  if (name == "relaxation") return HeightFromNormalsOptions::Method::kMultiresolutionRelaxation;
  if (name == "dct") return HeightFromNormalsOptions::Method::kDctPoisson;
  throw std::invalid_argument("height method '" + name + "' must be relaxation or dct");
}

std::string HeightFromNormalsSummary::BriefReport() const {
  std::string report = "Height from normals (" + (method.empty() ? std::string("?") : method) +
                       "): " + TerminationName(termination) + ", " + std::to_string(levels) + " level(s), " +
                       std::to_string(total_sweeps) + " sweep(s), " + (converged ? "converged" : "not converged") +
                       ", RMS slope residual " + Fixed(rms_slope_residual, 3) + ", " + Fixed(seconds, 2) + " s";
  if (termination != Termination::kSuccess) report += " (" + message + ")";
  return report;
}

HeightFromNormalsSummary HeightFromNormals(const HeightFromNormalsOptions& options, const ImageF& normal_in_tangent,
                                           const ImageU8* valid, ImageF* height_mm, const ProgressCallback& progress) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  CheckInputs(normal_in_tangent, valid, height_mm);
  HeightFromNormalsSummary summary;
  summary.method = HeightMethodName(options.method);
  const int width = normal_in_tangent.width(), height = normal_in_tangent.height();

  FullLevelSlopes full = SlopesFromNormals(normal_in_tangent, valid, options);
  if (full.valid_count == 0) {
    summary.SetFailure("no valid pixel with a finite normal in the " + std::to_string(width) + "x" +
                       std::to_string(height) + " map; height is all zero");
    summary.seconds = SecondsSince(start);
    *height_mm = ImageF(width, height, 1, 0.0f);
    return summary;
  }
  const bool all_valid = full.valid_count == full.level.num_pixels();
  BuildEdges(full.steps, &full.level);
  MarkInteriorRows(&full.level);

  const bool relaxation = options.method == HeightFromNormalsOptions::Method::kMultiresolutionRelaxation;
  MethodResult solved;
  if (relaxation) {
    full.steps = {};  // they live on in the edge targets
    solved = SolveByRelaxation(options, full.level, progress, &summary);
  } else {
    solved = SolveByDct(options, full.level, std::move(full.steps), all_valid, progress, &summary);
  }
  if (solved.cancelled) summary.converged = false;

  *height_mm = CentredHeight(full.level, solved.height_padded, full.valid_count, &summary.rms_slope_residual);
  summary.termination = solved.cancelled ? Termination::kCancelled : Termination::kSuccess;
  summary.seconds = SecondsSince(start);
  summary.message = Describe(summary, relaxation, solved.cancelled, full.valid_count, full.level.num_pixels(),
                             solved.hole_rounds, full.unusable_normals);
  return summary;
}

}  // namespace scanbench
