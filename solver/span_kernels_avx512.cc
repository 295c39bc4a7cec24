// The span kernels for avx512 (compile flags: solver/CMakeLists.txt).
#define SCANBENCH_ISA_NAMESPACE isa_avx512
#define SCANBENCH_ISA_ENUM KernelIsa::kAvx512
#include "solver/span_kernels_impl.h"
