// The network kernels for baseline (compile flags: solver/CMakeLists.txt).
#define SCANBENCH_ISA_NAMESPACE isa_baseline
#define SCANBENCH_ISA_ENUM KernelIsa::kBaseline
#include "solver/network_kernels_impl.h"
