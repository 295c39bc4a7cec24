#include "maps/height_from_normals.h"

// Implementation pending (issue #7 in progress).
