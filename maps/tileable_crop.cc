#include "maps/tileable_crop.h"

// Implementation pending (issue #7 in progress).
