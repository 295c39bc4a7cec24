// The colour kernels for avx512 (compile flags: calibration/CMakeLists.txt).
#define SCANBENCH_ISA_NAMESPACE isa_avx512
#define SCANBENCH_ISA_ENUM KernelIsa::kAvx512
#include "calibration/color_kernels_impl.h"
