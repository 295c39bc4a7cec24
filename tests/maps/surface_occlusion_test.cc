#include "maps/surface_occlusion.h"

#include <gtest/gtest.h>
