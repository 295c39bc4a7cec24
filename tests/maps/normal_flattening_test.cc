#include "maps/normal_flattening.h"

#include <gtest/gtest.h>
