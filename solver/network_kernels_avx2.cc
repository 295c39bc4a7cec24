// The network kernels for avx2 (compile flags: solver/CMakeLists.txt).
#define SCANBENCH_ISA_NAMESPACE isa_avx2
#define SCANBENCH_ISA_ENUM KernelIsa::kAvx2
#include "solver/network_kernels_impl.h"
