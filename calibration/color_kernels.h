// Internal to the calibration library: CIEDE2000 of many linear Rec.709 colour
// pairs (the solve's evaluation: 11 M of them at 16 MP), compiled once per
// instruction set (color_kernels_baseline.cc, _avx2.cc, _avx512.cc include
// color_kernels_impl.h) and picked at run time by the solver's dispatch
// (solver/cpu_dispatch.h: ActiveKernelIsa, SCANBENCH_SOLVER_ISA). Only plain
// data crosses this interface, as with the solver's span kernels.
#pragma once

#include <cstddef>
#include <cstdint>

#include "solver/cpu_dispatch.h"

namespace scanbench::color_kernels {

// Ciede2000FromLinearRec709 of `count` float pairs (interleaved RGB), the
// fast form's steps with polynomial atan2, exp and sin in double lanes.
// defer[i] = 1 where the fast form calls the published formula (a chroma near
// 0, hues 180 deg apart, a mean hue at the 0 / 360 deg wrap) or an input is not
// finite: delta_e[i] is then to be made by the caller; else 0.
struct Ciede2000Args {
  size_t count = 0;
  const float* rgb1 = nullptr;
  const float* rgb2 = nullptr;
  double* delta_e = nullptr;
  uint8_t* defer = nullptr;
  double xyz_over_white_from_rgb[9] = {};  // row-major: (XYZ / white) of linear Rec.709
  double cos30 = 0, sin30 = 0, cos6 = 0, sin6 = 0, cos63 = 0, sin63 = 0;  // T's offsets
  double min_chroma = 0, opposite_hue = 0, wrap_degrees = 0;            // the fast form's deferrals
};

struct ColorKernels {
  KernelIsa isa = KernelIsa::kBaseline;
  void (*ciede2000_from_linear_rec709)(const Ciede2000Args& args) = nullptr;
};

// The variant for `isa` (the baseline where that one is not built or not supported).
const ColorKernels& ColorKernelsFor(KernelIsa isa);

namespace isa_baseline { extern const ColorKernels kKernels; }
namespace isa_avx2 { extern const ColorKernels kKernels; }
namespace isa_avx512 { extern const ColorKernels kKernels; }

}  // namespace scanbench::color_kernels
