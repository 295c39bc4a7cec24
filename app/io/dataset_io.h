// Public photometric-stereo datasets on disk.
//
// DiLiGenT folder (distant lights):
//   NNN.png            one 16-bit linear RGB image per light (names in filenames.txt)
//   filenames.txt      image file names, one a line, in light order
//   light_directions.txt   one unit vector "x y z" a line
//   light_intensities.txt  one "R G B" a line
//   mask.png           non-zero on the object
//   Normal_gt.mat      optional, MATLAB variable Normal_gt, height x width x 3
// Frame: x right, y up, z towards the camera, for lights and normals alike.
//
// Near-field folder in the style of the LUCES dataset (point LEDs):
//   the images, filenames.txt (or the sorted NN.png files) and mask.png as above;
//   light_positions.txt    one LED position "x y z" a line, mm, OpenCV camera
//                          frame (x right, y down, z forward, camera centre at 0)
//   light_intensities.txt  one "R G B" a line: what a white Lambertian patch
//                          facing the LED on its axis reads at 1 mm (any
//                          common scale will do: it only scales the albedo)
//   light_directions.txt   optional, LED axis per light in the same camera frame
//                          (default: pointing at the surface centre)
//   light_mu.txt           optional, angular falloff cos^mu: one value for all
//                          lights or one a line (default 0, isotropic)
//   K.txt                  3x3 camera matrix, pixels (rows on lines)
//   mean_distance.txt      optional, mm from the camera to the surface plane
//                          (z = const) the first pass evaluates the light field
//                          on: as in LUCES, the object's mean distance (default:
//                          a guess from the LEDs); solve-dataset's depth
//                          refinement then finds the distance from the images
//                          (app/controllers/dataset_controller.h)
//   Normal_gt.mat          optional, as above
// Normals are solved and written in the solver frame of the DiLiGenT layout
// (x right, y up, z towards the camera); positions convert as (x, -y, -z).
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calibration/rig.h"
#include "core/image.h"
#include "solver/light_field.h"

namespace scanbench {

// A near-field dataset in the table frame of `scanbench solve` (calibration/
// rig.h), which the depth refinement works in (pipeline/depth_refinement.h):
// the solver frame moved by surface_distance_mm along z, so that the plane
// the first pass evaluates the LEDs on is the table z = 0 and the camera, a
// pinhole of camera_matrix without distortion, sits at (0, 0,
// surface_distance_mm) looking down -z. Normals are the same in both frames.
struct NearFieldTableFrame {
  CameraGeometry camera;
  std::vector<PointLight> lights;  // the LEDs in that frame, as MakeLightField's
};

struct PhotometricDataset {
  enum class Kind {
    kDistantLights,  // DiLiGenT
    kNearField,      // LUCES-style point LEDs
  };
  Kind kind = Kind::kDistantLights;
  std::filesystem::path folder;
  std::string name;                    // folder name
  int width = 0, height = 0;
  std::vector<std::string> image_files;
  std::vector<ImageF> images;          // RGB, integer files scaled to 0..1 (empty if not loaded)
  std::vector<Eigen::Vector3d> light_intensities;  // RGB per light
  // Distant lights: unit directions in the solver frame.
  std::vector<Eigen::Vector3d> light_directions;
  // Near field, in the solver frame (x right, y up, z towards the camera), mm.
  std::vector<Eigen::Vector3d> light_positions_mm;
  std::vector<Eigen::Vector3d> led_axes;  // unit, where each LED points
  std::vector<double> led_mu;             // angular falloff exponent per LED
  Eigen::Matrix3d camera_matrix = Eigen::Matrix3d::Identity();
  double surface_distance_mm = 0;         // camera to the surface plane
  ImageU8 mask;                           // 1 on the object
  std::optional<ImageF> normal_ground_truth;  // 3 channels, solver frame; (0,0,0) off the object

  int num_lights() const { return static_cast<int>(light_intensities.size()); }
  // The light field the solver needs: DirectionalLightField or PointLightField.
  std::unique_ptr<LightField> MakeLightField() const;
  std::vector<const ImageF*> ImagePointers() const;
  // Near field: the table frame above. Throws std::invalid_argument for a
  // distant-light dataset, and for a camera matrix CameraGeometry cannot
  // hold (a skew K(0,1) != 0, or a last row other than 0 0 1), naming K.txt.
  NearFieldTableFrame TableFrame() const;
  // Keeps only the lights `indices` (into today's lights, each once, any
  // order; kept in ascending order): images, file names and every per-light
  // table. Throws std::invalid_argument naming an index out of range or repeated.
  void KeepLights(std::vector<int> indices);
  // Directions of the lights for choosing a subset: the distant directions,
  // or for near-field LEDs the direction from the surface point on the
  // optical axis to each LED.
  std::vector<Eigen::Vector3d> CentralLightDirections() const;
};

struct DatasetLoadOptions {
  bool load_images = true;         // false: only lights, mask and ground truth
  bool load_ground_truth = true;   // read Normal_gt.mat when present
};

// True when `folder` looks like either layout (has filenames.txt or images
// and light_intensities.txt).
bool IsPhotometricDatasetFolder(const std::filesystem::path& folder);

// Throws std::runtime_error naming the file, the line and the rule broken.
PhotometricDataset LoadPhotometricDataset(const std::filesystem::path& folder,
                                          const DatasetLoadOptions& options = {});

// A height x width x 3 real array of a MAT file (v5, v7 or v7.3) as a
// 3-channel image (MATLAB's column-major order undone). Throws
// std::runtime_error naming the file and variable.
ImageF ReadMatImage3(const std::filesystem::path& path, const std::string& variable);
// Writes `image` (any channel count) as a height x width x channels double
// array, MAT v5, zlib-compressed; for tests and exports.
void WriteMatImage(const std::filesystem::path& path, const std::string& variable, const ImageF& image);

}  // namespace scanbench
