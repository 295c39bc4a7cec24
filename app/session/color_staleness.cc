#include "app/session/color_staleness.h"

#include "app/session/calibration_set.h"

namespace scanbench {
namespace fs = std::filesystem;

std::optional<std::string> StaleColorReason(const CalibrationSet& set, const fs::path& dir) {
  if (!set.color || set.color->white_reference != "light_field") return std::nullopt;
  const std::string set_name = (dir / kCalibrationManifestName).string();
  const auto fitted = ParseUtcTimestamp(set.color->date, set_name + ": color.date");
  std::string later;
  auto consider = [&](const std::optional<std::string>& date, const char* what) {
    if (!date || ParseUtcTimestamp(*date, set_name + ": " + what) <= fitted) return;
    later += (later.empty() ? "" : " and ") + std::string(what) + " " + *date;
  };
  consider(set.lights ? std::optional(set.lights->date) : std::nullopt, "the lights calibration of");
  consider(set.white_balance ? std::optional(set.white_balance->date) : std::nullopt, "the white balance of");
  if (later.empty()) return std::nullopt;
  std::string targets;
  for (const TargetCaptureRecord& target : set.color->targets) targets += " " + target.session;
  for (const RawFileRecord& file : set.color->raw_files) targets += " " + file.path;
  return set_name + ": color: stale: the colour correction of " + set.color->date +
         " was measured through the light field as it was then, before " + later +
         "; refit it: scanbench calibrate color" + targets + " -c " + dir.string();
}

}  // namespace scanbench
