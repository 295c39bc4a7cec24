#include "app/session/rig_json.h"

#include <cmath>
#include <map>
#include <stdexcept>

#include <Eigen/Geometry>

#include "app/io/file_util.h"
#include "app/session/json_field.h"
#include "calibration/camera_model.h"

namespace scanbench {
namespace session_internal {
namespace {

// Re-normalising a vector that is already unit can change its last bit, which
// would break the bit-exact write -> load round trip; only rescale real offenders.
constexpr double kUnitNormTolerance = 1e-12;
// How far R^T R may stray from the identity before cam_from_table is no rotation.
constexpr double kRotationTolerance = 1e-6;

Eigen::Vector3d NormalizedUnlessUnit(const Eigen::Vector3d& v) {
  return std::abs(v.norm() - 1.0) <= kUnitNormTolerance ? v : v.normalized();
}

template <typename Io>
void IntrinsicsFields(Io& io, CameraIntrinsics& k) {
  io.Field("width", k.width);
  io.Field("height", k.height);
  io.Field("fx", k.fx);
  io.Field("fy", k.fy);
  io.Field("cx", k.cx);
  io.Field("cy", k.cy);
  io.Field("k1", k.k1);
  io.Field("k2", k.k2);
  io.Field("k3", k.k3);
  io.Field("p1", k.p1);
  io.Field("p2", k.p2);
}

template <typename Io>
void QuaternionFields(Io& io, Eigen::Vector4d& wxyz) {
  io.Field("w", wxyz[0]);
  io.Field("x", wxyz[1]);
  io.Field("y", wxyz[2]);
  io.Field("z", wxyz[3]);
}

// The rotation is stored as a quaternion, read back as a matrix.
template <typename Io>
void PoseFields(Io& io, Eigen::Isometry3d& cam_from_table) {
  io.Custom(
      "rotation",
      [&] {
        Eigen::Quaterniond rotation(cam_from_table.linear());
        // q and -q are the same rotation; a positive w makes files comparable.
        if (rotation.w() < 0) rotation.coeffs() = -rotation.coeffs();
        const Eigen::Vector4d wxyz(rotation.w(), rotation.x(), rotation.y(), rotation.z());
        return ToJsonObject(wxyz, [](auto& q, Eigen::Vector4d& value) { QuaternionFields(q, value); });
      },
      [&](const JsonField& rotation_field) {
        const auto wxyz = FromJsonObject<Eigen::Vector4d>(
            rotation_field, [](auto& q, Eigen::Vector4d& value) { QuaternionFields(q, value); });
        const Eigen::Quaterniond rotation(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
        if (!rotation.coeffs().allFinite()) rotation_field.Fail("must be finite");
        // Only the direction of q matters; a hand-written 0.7071 is welcome.
        if (!(rotation.norm() > 0)) rotation_field.Fail("must be a non-zero quaternion");
        cam_from_table.linear() = rotation.normalized().toRotationMatrix();
      });
  io.Custom(
      "translation_mm", [&] { return Vector3ToJson(cam_from_table.translation()); },
      [&](const JsonField& translation) { cam_from_table.translation() = translation.Vector3(); });
}

template <typename Io>
void CameraGeometryFields(Io& io, CameraGeometry& camera) {
  io.Object("intrinsics", [&](auto& intrinsics) { IntrinsicsFields(intrinsics, camera.intrinsics); });
  io.Object("cam_from_table", [&](auto& pose) { PoseFields(pose, camera.cam_from_table); });
}

template <typename Io>
void LedFields(Io& io, LedDescription& led) {
  io.Field("id", led.id);
  io.Field("position_in_table_mm", led.position_in_table_mm);
  io.Custom(
      "axis_in_table", [&] { return Vector3ToJson(led.axis_in_table); },
      [&](const JsonField& axis_field) {
        const Eigen::Vector3d axis = axis_field.Vector3();
        if (!axis.allFinite()) axis_field.Fail("must be finite");
        if (!(axis.norm() > 0)) axis_field.Fail("must be a non-zero direction");
        led.axis_in_table = NormalizedUnlessUnit(axis);
      });
  io.Field("mu", led.mu);
  io.Field("rgb_intensity", led.rgb_intensity);
}

template <typename Io>
void RigFields(Io& io, RigDescription& rig) {
  io.Field("name", rig.name);
  io.Object("camera", [&](auto& camera) { CameraGeometryFields(camera, rig.camera); });
  io.Array("leds", rig.leds, [](auto& led_io, LedDescription& led) { LedFields(led_io, led); });
}

void CheckIntrinsics(const CameraIntrinsics& intrinsics, const std::string& file, const std::string& path) {
  try {
    CheckCameraIntrinsics(intrinsics);
  } catch (const std::invalid_argument& error) {
    // CheckCameraIntrinsics says "CameraIntrinsics.fx = 0 must be > 0"; the
    // path already says where.
    std::string message = error.what();
    const std::string redundant_prefix = "CameraIntrinsics.";
    if (message.rfind(redundant_prefix, 0) == 0) message.erase(0, redundant_prefix.size());
    ThrowFieldError(file, path, message);
  }
}

void CheckPose(const Eigen::Isometry3d& cam_from_table, const std::string& file, const std::string& path) {
  const Eigen::Matrix3d rotation = cam_from_table.linear();
  const std::string rotation_path = MemberPath(path, "rotation");
  if (!rotation.allFinite()) ThrowFieldError(file, rotation_path, "must be finite");
  const double orthogonality_error = (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthogonality_error > kRotationTolerance || !(rotation.determinant() > 0)) {
    ThrowFieldError(file, rotation_path,
                    "matrix with |R^T R - I| = " + FormatValue(orthogonality_error) + " and det " +
                        FormatValue(rotation.determinant()) + " must be a rotation");
  }
  if (!cam_from_table.translation().allFinite()) {
    ThrowFieldError(file, MemberPath(path, "translation_mm"),
                    FormatValue(Eigen::Vector3d(cam_from_table.translation())) + " must be finite");
  }
}

void CheckLed(const LedDescription& led, const std::string& file, const std::string& path) {
  if (led.id < 0) ThrowFieldError(file, MemberPath(path, "id"), std::to_string(led.id) + " must be >= 0");
  if (!led.position_in_table_mm.allFinite()) {
    ThrowFieldError(file, MemberPath(path, "position_in_table_mm"),
                    FormatValue(led.position_in_table_mm) + " must be finite");
  }
  const std::string axis_path = MemberPath(path, "axis_in_table");
  if (!led.axis_in_table.allFinite()) {
    ThrowFieldError(file, axis_path, FormatValue(led.axis_in_table) + " must be finite");
  }
  if (!(led.axis_in_table.norm() > 0)) {
    ThrowFieldError(file, axis_path, FormatValue(led.axis_in_table) + " must be a non-zero direction");
  }
  if (!std::isfinite(led.mu) || led.mu < 0) {
    ThrowFieldError(file, MemberPath(path, "mu"), FormatValue(led.mu) + " must be finite and >= 0");
  }
  if (!led.rgb_intensity.allFinite() || (led.rgb_intensity.array() < 0).any()) {
    ThrowFieldError(file, MemberPath(path, "rgb_intensity"),
                    FormatValue(led.rgb_intensity) + " must be finite and >= 0");
  }
}

}  // namespace

Json RigToJson(const RigDescription& rig) {
  return ToJsonObject(rig, [](auto& io, RigDescription& value) { RigFields(io, value); });
}

RigDescription RigFromJson(const JsonField& field) {
  return FromJsonObject<RigDescription>(field, [](auto& io, RigDescription& value) { RigFields(io, value); });
}

void CheckRig(const RigDescription& rig, const std::string& file, const std::string& path) {
  const std::string camera_path = MemberPath(path, "camera");
  CheckIntrinsics(rig.camera.intrinsics, file, MemberPath(camera_path, "intrinsics"));
  CheckPose(rig.camera.cam_from_table, file, MemberPath(camera_path, "cam_from_table"));
  const std::string leds_path = MemberPath(path, "leds");
  if (rig.leds.empty()) ThrowFieldError(file, leds_path, "[] must list at least one LED");
  std::map<int, size_t> index_of_id;
  for (size_t i = 0; i < rig.leds.size(); ++i) {
    const std::string led_path = ElementPath(leds_path, i);
    CheckLed(rig.leds[i], file, led_path);
    const auto [it, inserted] = index_of_id.emplace(rig.leds[i].id, i);
    if (!inserted) {
      ThrowFieldError(file, MemberPath(led_path, "id"),
                      std::to_string(rig.leds[i].id) + " is already used by " + ElementPath(leds_path, it->second));
    }
  }
}

Json CameraGeometryToJson(const CameraGeometry& camera) {
  return ToJsonObject(camera, [](auto& io, CameraGeometry& value) { CameraGeometryFields(io, value); });
}

CameraGeometry CameraGeometryFromJson(const JsonField& field) {
  return FromJsonObject<CameraGeometry>(field, [](auto& io, CameraGeometry& value) { CameraGeometryFields(io, value); });
}

void CheckCameraGeometry(const CameraGeometry& camera, const std::string& file, const std::string& path) {
  CheckIntrinsics(camera.intrinsics, file, MemberPath(path, "intrinsics"));
  CheckPose(camera.cam_from_table, file, MemberPath(path, "cam_from_table"));
}

Json LedDescriptionToJson(const LedDescription& led) {
  return ToJsonObject(led, [](auto& io, LedDescription& value) { LedFields(io, value); });
}

LedDescription LedDescriptionFromJson(const JsonField& field) {
  return FromJsonObject<LedDescription>(field, [](auto& io, LedDescription& value) { LedFields(io, value); });
}

void CheckLedDescription(const LedDescription& led, const std::string& file, const std::string& path) {
  CheckLed(led, file, path);
}

}  // namespace session_internal

std::string RigDescriptionToJson(const RigDescription& rig) {
  return session_internal::DumpJson(session_internal::RigToJson(rig));
}

RigDescription RigDescriptionFromJson(const std::string& text, const std::string& name_for_errors) {
  using namespace session_internal;
  const Json json = ParseJson(text, name_for_errors);
  RigDescription rig = RigFromJson(JsonField(json, "", name_for_errors));
  CheckRig(rig, name_for_errors, "");
  return rig;
}

RigDescription LoadRigDescriptionFile(const std::string& path) {
  const std::vector<uint8_t> bytes = ReadFileBytes(path);
  return RigDescriptionFromJson(std::string(bytes.begin(), bytes.end()), path);
}

void CheckRigDescription(const RigDescription& rig, const std::string& name_for_errors) {
  session_internal::CheckRig(rig, name_for_errors, "");
}

}  // namespace scanbench
