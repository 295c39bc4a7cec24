#include "maps/surface_occlusion.h"

// Implementation pending (issue #7 in progress).
