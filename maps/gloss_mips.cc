#include "maps/gloss_mips.h"

// Implementation pending (issue #7 in progress).
