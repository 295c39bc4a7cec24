// The network kernels for avx512 (compile flags: solver/CMakeLists.txt).
#define SCANBENCH_ISA_NAMESPACE isa_avx512
#define SCANBENCH_ISA_ENUM KernelIsa::kAvx512
#include "solver/network_kernels_impl.h"
