// Pixel <-> ray mapping of the calibrated pinhole camera with lens distortion.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "calibration/rig.h"
#include "core/image.h"

namespace scanbench {

// Throws std::invalid_argument naming the field when the intrinsics are unusable
// (non-positive size or focal length, principal point outside the image).
void CheckCameraIntrinsics(const CameraIntrinsics& intrinsics);

// Projects a camera-frame point (z > 0) to distorted pixel coordinates.
Eigen::Vector2d ProjectToPixel(const CameraIntrinsics& intrinsics, const Eigen::Vector3d& point_in_cam);

// Unit viewing rays, in the camera frame, through arbitrary (sub)pixel
// positions (pixel centres at integers): the lens distortion inverted as below.
std::vector<Eigen::Vector3d> ComputeRayDirectionsInCam(const CameraIntrinsics& intrinsics,
                                                       const std::vector<Eigen::Vector2d>& pixels);

// Where the ray of each (sub)pixel position meets the horizontal plane
// z = plane_height_mm of the table frame, in table mm. Throws
// std::invalid_argument if a ray does not reach the plane in front of the camera.
std::vector<Eigen::Vector3d> ComputePlanePointsInTable(const CameraGeometry& camera,
                                                       const std::vector<Eigen::Vector2d>& pixels,
                                                       double plane_height_mm);

// Unit viewing ray through every pixel centre, in the camera frame: 3 channels.
// The lens distortion is inverted iteratively (OpenCV), to well below 1e-6 px.
// Rows on `num_threads` threads of the pool (0 = all); the same values on any.
ImageF ComputeRayDirectionsInCam(const CameraIntrinsics& intrinsics, int num_threads = 0);

// Same rays, rotated into the table frame. All start at CameraCentreInTable().
ImageF ComputeRayDirectionsInTable(const CameraGeometry& camera, int num_threads = 0);

Eigen::Vector3d CameraCentreInTable(const CameraGeometry& camera);

// Footprint on the table plane (z = 0) of one pixel at the image centre, mm:
// the mean distance to the right and lower neighbours' table points (as the
// simulated rig computes it). The scale height maps are integrated at.
double TablePixelFootprintMm(const CameraGeometry& camera);

// Where every pixel's ray meets the table plane z = 0, in mm: 3 channels.
// Throws std::invalid_argument if the camera does not look at the table.
// Threads as ComputeRayDirectionsInCam.
ImageF ComputeTablePoints(const CameraGeometry& camera, int num_threads = 0);

// ComputeTablePoints' values of pixels (x0 + i, y), i < count, the same floats,
// interleaved into `xyz` (3 count floats), for callers that make them on
// request instead of holding 12 bytes a pixel. Throws as ComputeTablePoints.
void ComputeTablePointsOfSpan(const CameraGeometry& camera, int x0, int y, int count, float* xyz);
// The same of every step-th pixel of a row: pixels (x0 + i step, y), i < count
// (step >= 1), each undistorted on its own, so again the same floats.
void ComputeTablePointsOfRow(const CameraGeometry& camera, int x0, int step, int y, int count, float* xyz);

// The camera seen through blocks of block_px x block_px pixels: one pixel per
// whole block (floor(width / block_px) x floor(height / block_px); a partial
// block at the right or bottom edge is dropped), its centre at the block's
// centre. The lens distortion acts on normalised coordinates, so the scaled
// intrinsics keep it exactly. Throws std::invalid_argument when block_px < 1
// or the image has no whole block.
CameraGeometry BlockCamera(const CameraGeometry& camera, int block_px);

}  // namespace scanbench
