// Issue #36 item 14: whether a calibration set's colour section still fits
// the set's lights and white balance.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace scanbench {

struct CalibrationSet;

// A colour section measured through the set's light field (white_reference
// "light_field") is stale once the lights or the white balance were
// calibrated again after it: its patches were divided by the old field. It is
// marked, not refitted (a refit needs the chart captures again): the reason
// (naming <dir>/calibration.json, the dates and the command that refits it),
// or nullopt when the section is current (or absent, or "neutral_patches",
// which neither the lights nor the white balance enter).
std::optional<std::string> StaleColorReason(const CalibrationSet& set, const std::filesystem::path& dir);

}  // namespace scanbench
