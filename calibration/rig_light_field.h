// The light field the rig description predicts before any light calibration:
// every LED a point source, every pixel's surface point on the table plane.
#pragma once

#include <memory>
#include <vector>

#include "calibration/rig.h"
#include "solver/light_field.h"

namespace scanbench {

// The rig's LEDs as point lights, in the order of rig.leds. Throws
// std::invalid_argument naming the LED that is unusable.
std::vector<PointLight> RigPointLights(const RigDescription& rig);

// Lights in the order of rig.leds; the table points computed on `num_threads`
// threads (0 = all). Throws std::invalid_argument naming the LED or camera
// field that is unusable.
std::unique_ptr<PointLightField> MakeRigLightField(const RigDescription& rig, int num_threads = 0);

}  // namespace scanbench
