#include "maps/gloss_mips.h"

#include <gtest/gtest.h>
