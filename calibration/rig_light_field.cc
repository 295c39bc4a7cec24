#include "calibration/rig_light_field.h"

#include <string>

#include "calibration/camera_model.h"

namespace scanbench {

std::vector<PointLight> RigPointLights(const RigDescription& rig) {
  std::vector<PointLight> lights;
  for (size_t k = 0; k < rig.leds.size(); ++k) {
    const LedDescription& led = rig.leds[k];
    if (!(led.position_in_table_mm.z() > 0)) {
      throw std::invalid_argument("rig.leds[" + std::to_string(k) + "] (id " + std::to_string(led.id) +
                                  "): position_in_table_mm z = " + std::to_string(led.position_in_table_mm.z()) +
                                  " must be above the table (> 0)");
    }
    PointLight light;
    light.position = led.position_in_table_mm;
    light.axis = led.axis_in_table;
    light.mu = led.mu;
    light.rgb_intensity = led.rgb_intensity;
    light.reference_distance = kLedReferenceDistanceMm;
    lights.push_back(light);
  }
  return lights;
}

std::unique_ptr<PointLightField> MakeRigLightField(const RigDescription& rig, int num_threads) {
  return std::make_unique<PointLightField>(RigPointLights(rig), ComputeTablePoints(rig.camera, num_threads),
                                           CameraCentreInTable(rig.camera));
}

}  // namespace scanbench
