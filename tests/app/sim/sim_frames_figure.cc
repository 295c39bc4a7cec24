// Makes docs/images/sim_frames_<material>.png (docs/simulated-rig.md): the ten
// LED frames of the default scene at the default size, noise-free, in
// white-balanced camera RGB (RenderLinear divided by the camera's raw white),
// one stop brighter, box-averaged 6 x 6, sRGB-encoded, in a 5 x 2 grid with 4 px white gaps: top
// row LEDs 0-4 (the 30 deg ring), bottom row LEDs 5-9 (the 60 deg ring).
// Not a test: a tool target, built on request (cmake --build build --target
// sim_frames_figure), run as `sim_frames_figure MATERIAL OUT.png`.
#include <algorithm>
#include <cstdint>
#include <exception>
#include <iostream>

#include "app/io/image_io.h"
#include "app/sim/sensor_color.h"
#include "app/sim/simulated_rig.h"
#include "calibration/color_science.h"

int main(int argc, char** argv) {
  using namespace scanbench;
  if (argc != 3) {
    std::cerr << "usage: sim_frames_figure lambert|cloth|satin OUT.png\n";
    return 2;
  }
  try {
    const std::optional<SurfaceMaterial> material = SurfaceMaterialFromName(argv[1]);
    if (!material) throw std::invalid_argument(std::string("unknown material '") + argv[1] + "'");
    const SimulatedRigOptions options;  // the default size and camera (D5100)
    TextileSceneOptions scene;
    scene.material = *material;
    const SimulatedRig rig(options, TextileScene(scene),
                           MakeDefaultSimulatedRig(options.width, options.height, options.color));
    const Eigen::Vector3d raw_white = SimulatedSensorColor(options.color).raw_white_relative_to_green;
    constexpr int kScale = 6, kGap = 4, kColumns = 5, kRows = 2;
    constexpr double kExposure = 2.0;  // one stop up: the brightest LED puts a white at 0.72 of the range
    const int tile_w = options.width / kScale, tile_h = options.height / kScale;
    ImageU8 out(kColumns * tile_w + (kColumns - 1) * kGap, kRows * tile_h + (kRows - 1) * kGap, 3);
    std::fill(out.data(), out.data() + out.size(), uint8_t{255});
    for (int led = 0; led < rig.num_leds(); ++led) {
      const ImageF frame = rig.RenderLinear(led);
      const int x0 = (led % kColumns) * (tile_w + kGap), y0 = (led / kColumns) * (tile_h + kGap);
      for (int y = 0; y < tile_h; ++y) {
        for (int x = 0; x < tile_w; ++x) {
          for (int c = 0; c < 3; ++c) {
            double sum = 0;
            for (int dy = 0; dy < kScale; ++dy) {
              for (int dx = 0; dx < kScale; ++dx) sum += frame(kScale * x + dx, kScale * y + dy, c);
            }
            const double linear = kExposure * sum / (kScale * kScale) / raw_white[c];
            out(x0 + x, y0 + y, c) =
                static_cast<uint8_t>(std::lround(255.0 * SrgbEncode(std::clamp(linear, 0.0, 1.0))));
          }
        }
      }
    }
    WritePng(argv[2], out, OverwritePolicy::kReplace);
  } catch (const std::exception& e) {
    std::cerr << "sim_frames_figure: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
