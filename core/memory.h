// Process-wide memory behaviour, set once at the start of main().
#pragma once

namespace scanbench {

// Full-size images (16-200 MB each at 16 MP) come and go stage by stage.
// After the first large free glibc raises its mmap threshold to 32 MB and
// serves smaller blocks from its heaps, whose freed pages it keeps; a fixed
// 1 MiB threshold maps each image on its own and returns it whole when freed
// (solve at 16 MP: peak RSS 2.47 -> 2.02 GB, docs/solver.md "Memory"). Does
// nothing where the C library is not glibc. Call it before the first large
// allocation: the CLI, the GUI and the pipeline benchmark do.
void ReturnFreedImagesToTheSystem();

}  // namespace scanbench
