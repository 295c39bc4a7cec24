#include "calibration/color_checker.h"

#include "calibration/color_science.h"
#include "calibration/spectral_table.h"

namespace scanbench {

const std::vector<ColorCheckerPatch>& ColorCheckerClassic() {
  static const std::vector<ColorCheckerPatch> patches = [] {
    constexpr int kPatches = kColorCheckerRows * kColorCheckerColumns;
    const SpectralTable table = ParseSpectralTable("colorchecker_babelcolor_avg.csv", kPatches);
    std::vector<ColorCheckerPatch> result(kPatches);
    for (int i = 0; i < kPatches; ++i) {
      ColorCheckerPatch& patch = result[i];
      patch.name = table.names[i];
      patch.reflectance = table.columns[i];
      patch.linear_rec709 = LinearRec709OfReflectance(patch.reflectance);
      patch.lab_d65 = LabFromLinearRec709(patch.linear_rec709);
      patch.neutral = i >= (kColorCheckerRows - 1) * kColorCheckerColumns;
    }
    return result;
  }();
  return patches;
}

}  // namespace scanbench
