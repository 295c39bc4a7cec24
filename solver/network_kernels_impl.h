// The network kernels' source, compiled once per instruction set: each
// network_kernels_<isa>.cc defines SCANBENCH_ISA_NAMESPACE and
// SCANBENCH_ISA_ENUM and includes this file. Plain loops only, as in
// span_kernels_impl.h: no inline library function may be instantiated here.
#include "solver/kernel_math_impl.h"
#include "solver/network_kernels.h"

#ifndef SCANBENCH_ISA_NAMESPACE
#error "define SCANBENCH_ISA_NAMESPACE and SCANBENCH_ISA_ENUM before including network_kernels_impl.h"
#endif

namespace scanbench::network::SCANBENCH_ISA_NAMESPACE {
namespace {

// Columns per register block of the dense layer; every block's row stride is
// a multiple of it, so a block may read (never write) past `columns`.
constexpr int kCols = 16;
// Output rows per register block: 4 x 16 accumulators fit AVX2's registers.
constexpr int kRows = 4;

inline int MinInt(int a, int b) { return a < b ? a : b; }

using kernel_math::ExpNonPositiveF;

// The ISA's native float vector, by GCC's vector extension (element-wise
// arithmetic, no reassociation: every build computes each sum in the same
// order); kCols columns are kVectors of them. A wider generic vector would be
// split through the stack by GCC 12.
#if defined(__AVX512F__)
constexpr int kLanes = 16;
#elif defined(__AVX2__)
constexpr int kLanes = 8;
#else
constexpr int kLanes = 4;
#endif
constexpr int kVectors = kCols / kLanes;
typedef float Floats __attribute__((vector_size(kLanes * sizeof(float))));

inline Floats LoadFloats(const float* p) {
  Floats v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}

void Dense(const DenseArgs& a) {
  const Floats zero = {};
  for (int t0 = 0; t0 < a.columns; t0 += kCols) {
    const int n = MinInt(kCols, a.columns - t0);
    for (int j0 = 0; j0 < a.out; j0 += kRows) {
      const int rows = MinInt(kRows, a.out - j0);
      const float* w[kRows];
      Floats acc[kRows][kVectors];
      for (int r = 0; r < kRows; ++r) {
        const int row = r < rows ? j0 + r : j0;  // rows past `out` repeat the first, never stored
        w[r] = a.weight + static_cast<long>(row) * a.in;
        for (int v = 0; v < kVectors; ++v) acc[r][v] = zero + a.bias[row];
      }
      const float* xi = a.x + t0;
      for (int i = 0; i < a.in; ++i, xi += a.x_stride) {
        Floats xv[kVectors];
        for (int v = 0; v < kVectors; ++v) xv[v] = LoadFloats(xi + v * kLanes);
        for (int r = 0; r < kRows; ++r) {
          const float wr = w[r][i];
          for (int v = 0; v < kVectors; ++v) acc[r][v] += wr * xv[v];
        }
      }
      for (int r = 0; r < rows; ++r) {
        float* yr = a.y + static_cast<long>(j0 + r) * a.y_stride + t0;
        float lanes[kCols];
        for (int v = 0; v < kVectors; ++v) {
          Floats value = acc[r][v];
          if (a.accumulate) value = LoadFloats(yr + v * kLanes) + value;
          if (a.relu) value = value > zero ? value : zero;
          __builtin_memcpy(lanes + v * kLanes, &value, sizeof value);
        }
        for (int c = 0; c < n; ++c) yr[c] = lanes[c];
      }
    }
  }
}

void LayerNorm(const LayerNormArgs& a) {
  for (int t0 = 0; t0 < a.columns; t0 += kCols) {
    const int n = MinInt(kCols, a.columns - t0);
    float mean[kCols] = {}, var[kCols] = {};
    for (int i = 0; i < a.dim; ++i) {
      const float* xi = a.x + static_cast<long>(i) * a.stride + t0;
      for (int c = 0; c < kCols; ++c) mean[c] += xi[c];
    }
    for (int c = 0; c < kCols; ++c) mean[c] /= static_cast<float>(a.dim);
    for (int i = 0; i < a.dim; ++i) {
      const float* xi = a.x + static_cast<long>(i) * a.stride + t0;
      for (int c = 0; c < kCols; ++c) {
        const float d = xi[c] - mean[c];
        var[c] += d * d;
      }
    }
    float inv[kCols];
    for (int c = 0; c < kCols; ++c) inv[c] = 1.0f / __builtin_sqrtf(var[c] / static_cast<float>(a.dim) + a.epsilon);
    for (int i = 0; i < a.dim; ++i) {
      const float* xi = a.x + static_cast<long>(i) * a.stride + t0;
      float* yi = a.y + static_cast<long>(i) * a.stride + t0;
      const float g = a.gamma[i], b = a.beta[i];
      for (int c = 0; c < n; ++c) yi[c] = (xi[c] - mean[c]) * inv[c] * g + b;
    }
  }
}

void Attention(const AttentionArgs& a) {
  const int d = a.width / a.heads;
  const float scale = 1.0f / __builtin_sqrtf(static_cast<float>(d));
  for (int p = 0; p < a.segments.num_pixels; ++p) {
    const int begin = a.segments.begin[p], k = a.segments.begin[p + 1] - begin;
    for (int h = 0; h < a.heads; ++h) {
      const float* q = a.qkv + static_cast<long>(h * d) * a.stride + begin;
      const float* kk = a.qkv + static_cast<long>(a.width + h * d) * a.stride + begin;
      const float* v = a.qkv + static_cast<long>(2 * a.width + h * d) * a.stride + begin;
      float* s = a.scratch;  // k x k: row = query
      for (int i = 0; i < k * k; ++i) s[i] = 0.0f;
      for (int r = 0; r < d; ++r) {
        const float* qr = q + static_cast<long>(r) * a.stride;
        const float* kr = kk + static_cast<long>(r) * a.stride;
        for (int i = 0; i < k; ++i) {
          const float qi = qr[i];
          float* si = s + i * k;
          for (int j = 0; j < k; ++j) si[j] += qi * kr[j];
        }
      }
      for (int i = 0; i < k; ++i) {
        float* si = s + i * k;
        float peak = -3.0e38f;
        for (int j = 0; j < k; ++j) {
          si[j] *= scale;
          peak = si[j] > peak ? si[j] : peak;
        }
        float sum = 0.0f;
        for (int j = 0; j < k; ++j) {
          si[j] = ExpNonPositiveF(si[j] - peak);
          sum += si[j];
        }
        const float inv = 1.0f / sum;
        for (int j = 0; j < k; ++j) si[j] *= inv;
      }
      for (int r = 0; r < d; ++r) {
        const float* vr = v + static_cast<long>(r) * a.stride;
        float* yr = a.y + static_cast<long>(h * d + r) * a.stride + begin;
        for (int i = 0; i < k; ++i) {
          const float* si = s + i * k;
          float sum = 0.0f;
          for (int j = 0; j < k; ++j) sum += si[j] * vr[j];
          yr[i] = sum;
        }
      }
    }
  }
}

void Pool(const PoolArgs& a) {
  for (int p = 0; p < a.segments.num_pixels; ++p) {
    const int begin = a.segments.begin[p], end = a.segments.begin[p + 1];
    const float inv = 1.0f / static_cast<float>(end - begin > 0 ? end - begin : 1);
    for (int i = 0; i < a.dim; ++i) {
      const float* xi = a.x + static_cast<long>(i) * a.x_stride;
      float peak = -3.0e38f, sum = 0.0f;
      for (int t = begin; t < end; ++t) {
        peak = xi[t] > peak ? xi[t] : peak;
        sum += xi[t];
      }
      a.z[static_cast<long>(i) * a.z_stride + p] = peak;
      a.z[static_cast<long>(a.dim + i) * a.z_stride + p] = sum * inv;
    }
  }
}

void BroadcastAdd(const BroadcastAddArgs& a) {
  for (int i = 0; i < a.dim; ++i) {
    float* xi = a.x + static_cast<long>(i) * a.x_stride;
    const float* gi = a.g + static_cast<long>(i) * a.g_stride;
    for (int p = 0; p < a.segments.num_pixels; ++p) {
      const float g = gi[p];
      for (int t = a.segments.begin[p]; t < a.segments.begin[p + 1]; ++t) {
        const float v = xi[t] + g;
        xi[t] = a.relu ? (v > 0.0f ? v : 0.0f) : v;
      }
    }
  }
}

}  // namespace

const NetworkKernels kKernels{SCANBENCH_ISA_ENUM, &Dense, &LayerNorm, &Attention, &Pool, &BroadcastAdd};

}  // namespace scanbench::network::SCANBENCH_ISA_NAMESPACE
