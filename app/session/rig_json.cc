#include "app/session/rig_json.h"

#include <cmath>
#include <map>
#include <stdexcept>

#include <Eigen/Geometry>

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

Json IntrinsicsToJson(const CameraIntrinsics& k) {
  return Json{{"width", k.width}, {"height", k.height}, {"fx", k.fx}, {"fy", k.fy},
              {"cx", k.cx},       {"cy", k.cy},         {"k1", k.k1}, {"k2", k.k2},
              {"k3", k.k3},       {"p1", k.p1},         {"p2", k.p2}};
}

CameraIntrinsics IntrinsicsFromJson(const JsonField& field) {
  field.ExpectOnlyKeys({"width", "height", "fx", "fy", "cx", "cy", "k1", "k2", "k3", "p1", "p2"});
  CameraIntrinsics k;
  k.width = field.Member("width").Int();
  k.height = field.Member("height").Int();
  k.fx = field.Member("fx").Double();
  k.fy = field.Member("fy").Double();
  k.cx = field.Member("cx").Double();
  k.cy = field.Member("cy").Double();
  k.k1 = field.Member("k1").Double();
  k.k2 = field.Member("k2").Double();
  k.k3 = field.Member("k3").Double();
  k.p1 = field.Member("p1").Double();
  k.p2 = field.Member("p2").Double();
  return k;
}

Json PoseToJson(const Eigen::Isometry3d& cam_from_table) {
  Eigen::Quaterniond rotation(cam_from_table.linear());
  // q and -q are the same rotation; a positive w makes files comparable.
  if (rotation.w() < 0) rotation.coeffs() = -rotation.coeffs();
  return Json{{"rotation", {{"w", rotation.w()}, {"x", rotation.x()}, {"y", rotation.y()}, {"z", rotation.z()}}},
              {"translation_mm", Vector3ToJson(cam_from_table.translation())}};
}

Eigen::Isometry3d PoseFromJson(const JsonField& field) {
  field.ExpectOnlyKeys({"rotation", "translation_mm"});
  const JsonField rotation_field = field.Member("rotation");
  rotation_field.ExpectOnlyKeys({"w", "x", "y", "z"});
  Eigen::Quaterniond rotation(rotation_field.Member("w").Double(), rotation_field.Member("x").Double(),
                              rotation_field.Member("y").Double(), rotation_field.Member("z").Double());
  if (!rotation.coeffs().allFinite()) rotation_field.Fail("must be finite");
  // Only the direction of q matters; a hand-written 0.7071 is welcome.
  if (!(rotation.norm() > 0)) rotation_field.Fail("must be a non-zero quaternion");
  Eigen::Isometry3d cam_from_table = Eigen::Isometry3d::Identity();
  cam_from_table.linear() = rotation.normalized().toRotationMatrix();
  cam_from_table.translation() = field.Member("translation_mm").Vector3();
  return cam_from_table;
}

Json LedToJson(const LedDescription& led) {
  return Json{{"id", led.id},
              {"position_in_table_mm", Vector3ToJson(led.position_in_table_mm)},
              {"axis_in_table", Vector3ToJson(led.axis_in_table)},
              {"mu", led.mu},
              {"rgb_intensity", Vector3ToJson(led.rgb_intensity)}};
}

LedDescription LedFromJson(const JsonField& field) {
  field.ExpectOnlyKeys({"id", "position_in_table_mm", "axis_in_table", "mu", "rgb_intensity"});
  LedDescription led;
  led.id = field.Member("id").Int();
  led.position_in_table_mm = field.Member("position_in_table_mm").Vector3();
  const JsonField axis_field = field.Member("axis_in_table");
  const Eigen::Vector3d axis = axis_field.Vector3();
  if (!axis.allFinite()) axis_field.Fail("must be finite");
  if (!(axis.norm() > 0)) axis_field.Fail("must be a non-zero direction");
  led.axis_in_table = NormalizedUnlessUnit(axis);
  led.mu = field.Member("mu").Double();
  led.rgb_intensity = field.Member("rgb_intensity").Vector3();
  return led;
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
  Json leds = Json::array();
  for (const LedDescription& led : rig.leds) leds.push_back(LedToJson(led));
  return Json{{"name", rig.name},
              {"camera",
               {{"intrinsics", IntrinsicsToJson(rig.camera.intrinsics)},
                {"cam_from_table", PoseToJson(rig.camera.cam_from_table)}}},
              {"leds", std::move(leds)}};
}

RigDescription RigFromJson(const JsonField& field) {
  field.ExpectOnlyKeys({"name", "camera", "leds"});
  RigDescription rig;
  rig.name = field.Member("name").String();
  const JsonField camera = field.Member("camera");
  camera.ExpectOnlyKeys({"intrinsics", "cam_from_table"});
  rig.camera.intrinsics = IntrinsicsFromJson(camera.Member("intrinsics"));
  rig.camera.cam_from_table = PoseFromJson(camera.Member("cam_from_table"));
  for (const JsonField& led : field.Member("leds").Elements()) rig.leds.push_back(LedFromJson(led));
  return rig;
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
  return Json{{"intrinsics", IntrinsicsToJson(camera.intrinsics)}, {"cam_from_table", PoseToJson(camera.cam_from_table)}};
}

CameraGeometry CameraGeometryFromJson(const JsonField& field) {
  field.ExpectOnlyKeys({"intrinsics", "cam_from_table"});
  CameraGeometry camera;
  camera.intrinsics = IntrinsicsFromJson(field.Member("intrinsics"));
  camera.cam_from_table = PoseFromJson(field.Member("cam_from_table"));
  return camera;
}

void CheckCameraGeometry(const CameraGeometry& camera, const std::string& file, const std::string& path) {
  CheckIntrinsics(camera.intrinsics, file, MemberPath(path, "intrinsics"));
  CheckPose(camera.cam_from_table, file, MemberPath(path, "cam_from_table"));
}

Json LedDescriptionToJson(const LedDescription& led) { return LedToJson(led); }
LedDescription LedDescriptionFromJson(const JsonField& field) { return LedFromJson(field); }
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

void CheckRigDescription(const RigDescription& rig, const std::string& name_for_errors) {
  session_internal::CheckRig(rig, name_for_errors, "");
}

}  // namespace scanbench
