// The learned solver's hot loops (solver/normal_network.h): dense layers,
// layer norms, per-pixel attention and pooling on FEATURE-MAJOR blocks (row i
// holds feature i of every token, `stride` floats apart), so each loop runs
// along the tokens and vectorises. Compiled once per instruction set
// (network_kernels_{baseline,avx2,avx512}.cc) and picked at run time
// (solver/cpu_dispatch.h); without floating-point contraction, so every
// variant gives the baseline's results.
#pragma once

#include "solver/cpu_dispatch.h"

namespace scanbench::network {

// A block of tokens of whole pixels: pixel p owns columns [begin[p], begin[p + 1]).
struct Segments {
  const int* begin = nullptr;  // num_pixels + 1 entries, begin[0] = 0
  int num_pixels = 0;
};

struct DenseArgs {
  const float* weight = nullptr;  // out x in, row-major (PyTorch's Linear.weight)
  const float* bias = nullptr;    // out
  int in = 0, out = 0;
  const float* x = nullptr;       // in rows of `columns`, `x_stride` apart
  int x_stride = 0;
  float* y = nullptr;             // out rows of `columns`, `y_stride` apart
  int y_stride = 0;
  int columns = 0;
  bool relu = false;              // y = max(0, .)
  bool accumulate = false;        // y += W x + b instead of y = W x + b (a residual)
};

struct LayerNormArgs {
  const float* gamma = nullptr;   // dim
  const float* beta = nullptr;    // dim
  int dim = 0;
  const float* x = nullptr;       // dim rows
  float* y = nullptr;             // dim rows (may not alias x)
  int stride = 0, columns = 0;
  float epsilon = 1e-5f;          // PyTorch's default
};

struct AttentionArgs {
  const float* qkv = nullptr;     // 3 width rows: queries, keys, values, each `heads` groups of width / heads rows
  float* y = nullptr;             // width rows: the heads' outputs, concatenated
  int stride = 0, width = 0, heads = 0;
  Segments segments;              // attention runs within each pixel's tokens only
  float* scratch = nullptr;       // at least max_tokens^2 floats
};

struct PoolArgs {
  const float* x = nullptr;       // dim rows of tokens
  int dim = 0, x_stride = 0;
  Segments segments;
  float* z = nullptr;             // 2 dim rows of pixels: the max over a pixel's tokens, then the mean
  int z_stride = 0;
};

// x[:, t] += g[:, pixel of t], then max(0, .) when relu (deepset2's context term).
struct BroadcastAddArgs {
  float* x = nullptr;
  int dim = 0, x_stride = 0;
  const float* g = nullptr;
  int g_stride = 0;
  Segments segments;
  bool relu = false;
};

struct NetworkKernels {
  KernelIsa isa = KernelIsa::kBaseline;
  void (*dense)(const DenseArgs& args) = nullptr;
  void (*layer_norm)(const LayerNormArgs& args) = nullptr;
  void (*attention)(const AttentionArgs& args) = nullptr;
  void (*pool)(const PoolArgs& args) = nullptr;
  void (*broadcast_add)(const BroadcastAddArgs& args) = nullptr;
};

// The kernels built for `isa` (which must be supported: KernelIsaSupported).
const NetworkKernels& NetworkKernelsFor(KernelIsa isa);

namespace isa_baseline { extern const NetworkKernels kKernels; }
namespace isa_avx2 { extern const NetworkKernels kKernels; }
namespace isa_avx512 { extern const NetworkKernels kKernels; }

}  // namespace scanbench::network
