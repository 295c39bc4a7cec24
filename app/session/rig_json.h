// RigDescription <-> JSON. A session embeds it under "rig"; a calibration set
// stores it alone.
//
// Layout (millimetres, table frame as in calibration/rig.h):
//   {"name": "bench-a",
//    "camera": {"intrinsics": {"width", "height", "fx", "fy", "cx", "cy",
//                              "k1", "k2", "k3", "p1", "p2"},
//               "cam_from_table": {"rotation": {"w", "x", "y", "z"},
//                                  "translation_mm": [x, y, z]}},
//    "leds": [{"id", "position_in_table_mm": [x, y, z], "axis_in_table": [x, y, z],
//              "mu", "rgb_intensity": [r, g, b]}, ...]}
#pragma once

#include <string>

#include "app/session/session_error.h"
#include "calibration/rig.h"

namespace scanbench {

std::string RigDescriptionToJson(const RigDescription& rig);

// Parses and checks (CheckRigDescription). `name_for_errors` (usually the file
// path) starts every error message. Throws SessionError.
RigDescription RigDescriptionFromJson(const std::string& text, const std::string& name_for_errors);

// Throws SessionError naming the field when the rig is unusable: invalid camera
// intrinsics, cam_from_table not a rotation, non-finite numbers, zero LED axis,
// mu < 0, negative intensity, duplicate or negative LED ids, no LEDs.
void CheckRigDescription(const RigDescription& rig, const std::string& name_for_errors);

// Reads a rig description file (capture --rig-file, import --rig); errors
// start with the path. Throws SessionError, or std::runtime_error when the
// file cannot be read.
RigDescription LoadRigDescriptionFile(const std::string& path);

}  // namespace scanbench
