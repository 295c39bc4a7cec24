#include "maps/tileable_crop.h"

#include <gtest/gtest.h>
