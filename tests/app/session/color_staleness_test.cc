#include "app/session/color_staleness.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/session/calibration_set.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;

// Issue #36 item 14: a colour section measured through the light field goes
// stale once the lights or the white balance are calibrated after it; the
// reason names the dates and the command that refits it. A section measured
// on the chart's gray row never goes stale.
TEST(ColorStalenessTest, AColourSectionIsStaleOnceTheLightsOrWhiteBalanceComeAfterIt) {
  CalibrationSet set;
  EXPECT_EQ(StaleColorReason(set, "cal"), std::nullopt);
  set.white_balance = WhiteBalanceSection{};
  set.white_balance->date = "2026-12-01T10:00:00.000Z";
  set.lights = LightsSection{};
  set.lights->date = "2026-12-01T11:00:00.000Z";
  set.color = ColorSection{};
  set.color->date = "2026-12-01T12:00:00.000Z";
  set.color->white_reference = "light_field";
  set.color->targets.push_back(TargetCaptureRecord{"targets/color_chart", "color_chart", "", "", "", {}});
  EXPECT_EQ(StaleColorReason(set, "cal"), std::nullopt) << "fitted after both";

  set.lights->date = "2026-12-02T09:00:00.000Z";
  const std::optional<std::string> stale = StaleColorReason(set, "cal");
  ASSERT_TRUE(stale.has_value());
  EXPECT_EQ(*stale,
            "cal/calibration.json: color: stale: the colour correction of 2026-12-01T12:00:00.000Z was measured "
            "through the light field as it was then, before the lights calibration of 2026-12-02T09:00:00.000Z; "
            "refit it: scanbench calibrate color targets/color_chart -c cal");
  set.white_balance->date = "2026-12-02T10:00:00.000Z";
  EXPECT_THAT(*StaleColorReason(set, "cal"),
              HasSubstr("before the lights calibration of 2026-12-02T09:00:00.000Z and the white balance of "
                        "2026-12-02T10:00:00.000Z"));
  set.color->white_reference = "neutral_patches";
  EXPECT_EQ(StaleColorReason(set, "cal"), std::nullopt);
}

}  // namespace
}  // namespace scanbench
