#include "core/memory.h"

#if defined(__GLIBC__)
#include <malloc.h>  // mallopt
#endif

namespace scanbench {

void ReturnFreedImagesToTheSystem() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 1 << 20);
#endif
}

}  // namespace scanbench
