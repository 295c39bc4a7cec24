// Which matrix takes a session's solved albedo to linear Rec.709 (issue #12):
// the calibration set's colour calibration, else the RAW files' camera matrix,
// else none, and whether its scale is absolute reflectance.
#pragma once

#include <optional>
#include <string>

#include <Eigen/Core>

#include "pipeline/albedo_color.h"

namespace scanbench {

struct CalibrationSet;

// Decides the albedo's colour. `set` is the calibration set the solve uses (null
// = none); `file_camera_from_xyz` is the RAW files' camera matrix (XYZ -> camera
// native, D65) when they carry one, `file_name` the file it was read from.
// Throws std::runtime_error when options ask for a source that is not there.
AlbedoColor ChooseAlbedoColor(const AlbedoColorOptions& options, const CalibrationSet* set,
                              const std::string& set_name,
                              const std::optional<Eigen::Matrix3d>& file_camera_from_xyz,
                              const std::string& file_name);

}  // namespace scanbench
