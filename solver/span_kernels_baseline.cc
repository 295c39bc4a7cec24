// The span kernels for baseline (compile flags: solver/CMakeLists.txt).
#define SCANBENCH_ISA_NAMESPACE isa_baseline
#define SCANBENCH_ISA_ENUM KernelIsa::kBaseline
#include "solver/span_kernels_impl.h"
