#include "solver/cpu_dispatch.h"

#include <atomic>
#include <cstdlib>
#include <stdexcept>

#include "solver/network_kernels.h"
#include "solver/span_kernels.h"

namespace scanbench {

const char* KernelIsaName(KernelIsa isa) {
  switch (isa) {
    case KernelIsa::kBaseline: return "baseline";
    case KernelIsa::kAvx2: return "avx2";
    case KernelIsa::kAvx512: return "avx512";
  }
  return "?";
}

bool KernelIsaFromName(const std::string& name, KernelIsa* isa) {
  for (KernelIsa candidate : {KernelIsa::kBaseline, KernelIsa::kAvx2, KernelIsa::kAvx512}) {
    if (name == KernelIsaName(candidate)) {
      *isa = candidate;
      return true;
    }
  }
  return false;
}

bool KernelIsaSupported(KernelIsa isa) {
  switch (isa) {
    case KernelIsa::kBaseline: return true;
#ifdef SCANBENCH_ISA_VARIANTS
    // libgcc's checks include the OS saving the wider registers (XCR0).
    case KernelIsa::kAvx2: return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case KernelIsa::kAvx512:
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
             __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq") &&
             KernelIsaSupported(KernelIsa::kAvx2);
#endif
    default: return false;
  }
}

std::vector<KernelIsa> SupportedKernelIsas() {
  std::vector<KernelIsa> supported;
  for (KernelIsa isa : {KernelIsa::kBaseline, KernelIsa::kAvx2, KernelIsa::kAvx512}) {
    if (KernelIsaSupported(isa)) supported.push_back(isa);
  }
  return supported;
}

KernelIsa DefaultKernelIsa() {
  static const KernelIsa chosen = [] {
    KernelIsa best = SupportedKernelIsas().back();
    KernelIsa cap;
    const char* forced = std::getenv("SCANBENCH_SOLVER_ISA");
    // An unknown name is no cap: the summary names the ISA that ran.
    if (forced != nullptr && KernelIsaFromName(forced, &cap) && static_cast<int>(cap) < static_cast<int>(best)) {
      best = cap;
    }
    return best;
  }();
  return chosen;
}

namespace {
std::atomic<int> override_isa{-1};  // -1: none
}  // namespace

KernelIsa ActiveKernelIsa() {
  const int forced = override_isa.load(std::memory_order_relaxed);
  return forced >= 0 ? static_cast<KernelIsa>(forced) : DefaultKernelIsa();
}

void OverrideKernelIsa(KernelIsa isa) {
  if (!KernelIsaSupported(isa)) {
    std::string supported;
    for (KernelIsa s : SupportedKernelIsas()) supported += std::string(supported.empty() ? "" : ", ") + KernelIsaName(s);
    throw std::invalid_argument(std::string("OverrideKernelIsa: kernel ISA ") + KernelIsaName(isa) +
                                " is not supported by this CPU or build (supported: " + supported + ")");
  }
  override_isa.store(static_cast<int>(isa), std::memory_order_relaxed);
}

void ClearKernelIsaOverride() { override_isa.store(-1, std::memory_order_relaxed); }

namespace tiled {

const SpanKernels& SpanKernelsFor(KernelIsa isa) {
#ifdef SCANBENCH_ISA_VARIANTS
  return KernelsOfIsa(isa, isa_baseline::kKernels, &isa_avx2::kKernels, &isa_avx512::kKernels);
#else
  return KernelsOfIsa<SpanKernels>(isa, isa_baseline::kKernels, nullptr, nullptr);
#endif
}

}  // namespace tiled

namespace network {

const NetworkKernels& NetworkKernelsFor(KernelIsa isa) {
#ifdef SCANBENCH_ISA_VARIANTS
  return KernelsOfIsa(isa, isa_baseline::kKernels, &isa_avx2::kKernels, &isa_avx512::kKernels);
#else
  return KernelsOfIsa<NetworkKernels>(isa, isa_baseline::kKernels, nullptr, nullptr);
#endif
}

}  // namespace network
}  // namespace scanbench
