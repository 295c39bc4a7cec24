// Which instruction set the solver's hot loops run on. The library is built
// for the x86-64 baseline (SSE2) and carries the same loops compiled for
// AVX2 + FMA and for AVX-512 besides (solver/span_kernels_*.cc); one is picked
// at run time from what the CPU supports, so one binary runs everywhere and
// uses what it finds. The variants give the same results (the kernels are
// built without floating-point contraction: see solver/CMakeLists.txt).
#pragma once

#include <string>
#include <vector>

namespace scanbench {

enum class KernelIsa {
  kBaseline,  // x86-64 baseline (SSE2), or the host's default where not x86-64
  kAvx2,      // AVX2 + FMA
  kAvx512,    // AVX-512 F, VL, BW, DQ
};

// "baseline", "avx2", "avx512" (the names SCANBENCH_SOLVER_ISA takes).
const char* KernelIsaName(KernelIsa isa);
// False when `name` is none of those.
bool KernelIsaFromName(const std::string& name, KernelIsa* isa);

// Built into this library and supported by this CPU.
bool KernelIsaSupported(KernelIsa isa);
// Every supported one, baseline first.
std::vector<KernelIsa> SupportedKernelIsas();

// The best supported, capped by the environment variable SCANBENCH_SOLVER_ISA
// where it names one (e.g. =baseline to debug or compare against the
// baseline; an unknown name caps nothing). Decided once per process.
KernelIsa DefaultKernelIsa();

// What a solve starting now runs (each solve picks once, at its start): the
// override where one is set, else DefaultKernelIsa(). Not an option of the
// solve, since every ISA gives the same results.
KernelIsa ActiveKernelIsa();
// Process-wide, for tests and debugging: solves started afterwards run `isa`
// (which must be supported: throws std::invalid_argument naming it and the
// supported ones otherwise) until ClearKernelIsaOverride().
void OverrideKernelIsa(KernelIsa isa);
void ClearKernelIsaOverride();

// The table of `isa` among a library's per-ISA builds of one kernel set (the
// span kernels, the colour kernels): `avx2` and `avx512` are null where the
// build has no such variant; an ISA this CPU lacks gives the baseline's.
template <typename Kernels>
const Kernels& KernelsOfIsa(KernelIsa isa, const Kernels& baseline, const Kernels* avx2, const Kernels* avx512) {
  if (isa == KernelIsa::kAvx512 && avx512 != nullptr && KernelIsaSupported(isa)) return *avx512;
  if (isa == KernelIsa::kAvx2 && avx2 != nullptr && KernelIsaSupported(isa)) return *avx2;
  return baseline;
}

}  // namespace scanbench
