#include "maps/normal_flattening.h"

// Implementation pending (issue #7 in progress).
