#include "maps/height_from_normals.h"

#include <gtest/gtest.h>
