// The colour kernels for baseline (compile flags: calibration/CMakeLists.txt).
#define SCANBENCH_ISA_NAMESPACE isa_baseline
#define SCANBENCH_ISA_ENUM KernelIsa::kBaseline
#include "calibration/color_kernels_impl.h"
