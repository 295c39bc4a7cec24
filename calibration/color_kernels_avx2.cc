// The colour kernels for avx2 (compile flags: calibration/CMakeLists.txt).
#define SCANBENCH_ISA_NAMESPACE isa_avx2
#define SCANBENCH_ISA_ENUM KernelIsa::kAvx2
#include "calibration/color_kernels_impl.h"
