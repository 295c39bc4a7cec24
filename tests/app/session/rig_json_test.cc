#include "app/session/rig_json.h"

#include <functional>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/app/session/session_test_util.h"

namespace scanbench {
namespace {

using testing_util::ErrorMessageOf;
using testing_util::ExpectFieldError;
using testing_util::ExpectSameRig;
using testing_util::MakeTestRig;
using Json = nlohmann::ordered_json;

constexpr char kRigFile[] = "/calib/rig.json";

std::string RigErrorAfter(const std::function<void(Json&)>& corrupt) {
  Json json = Json::parse(RigDescriptionToJson(MakeTestRig()));
  corrupt(json);
  return ErrorMessageOf([&] { RigDescriptionFromJson(json.dump(2), kRigFile); });
}

TEST(RigJsonTest, RoundTripKeepsEveryDouble) {
  const RigDescription rig = MakeTestRig();
  const RigDescription loaded = RigDescriptionFromJson(RigDescriptionToJson(rig), kRigFile);
  ExpectSameRig(rig, loaded);
}

TEST(RigJsonTest, WritesDocumentedLayout) {
  const Json json = Json::parse(RigDescriptionToJson(MakeTestRig()));
  EXPECT_EQ(json["name"], "bench-a \xc3\xa9");
  EXPECT_EQ(json["camera"]["intrinsics"]["width"], 6000);
  const Json& rotation = json["camera"]["cam_from_table"]["rotation"];
  EXPECT_GE(rotation["w"].get<double>(), 0.0);  // canonical sign
  EXPECT_EQ(json["camera"]["cam_from_table"]["translation_mm"].size(), 3u);
  ASSERT_EQ(json["leds"].size(), 3u);
  for (const char* key : {"id", "position_in_table_mm", "axis_in_table", "mu", "rgb_intensity"}) {
    EXPECT_TRUE(json["leds"][0].contains(key)) << key;
  }
}

TEST(RigJsonTest, NormalisesHandWrittenAxisAndQuaternion) {
  Json json = Json::parse(RigDescriptionToJson(MakeTestRig()));
  json["leds"][1]["axis_in_table"] = Json::array({0, 0, -2});
  json["camera"]["cam_from_table"]["rotation"] = Json{{"w", 0}, {"x", 0.7071}, {"y", 0.7071}, {"z", 0}};
  const RigDescription rig = RigDescriptionFromJson(json.dump(), kRigFile);
  EXPECT_EQ(rig.leds[1].axis_in_table, Eigen::Vector3d(0, 0, -1));
  const Eigen::Matrix3d rotation = rig.camera.cam_from_table.linear();
  EXPECT_LE((rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(RigJsonTest, RejectsBadJsonWithLineAndColumn) {
  const std::string message =
      ErrorMessageOf([] { RigDescriptionFromJson("{\n  \"name\": \"a\"\n  \"leds\": []\n}\n", kRigFile); });
  EXPECT_THAT(message, ::testing::StartsWith(std::string(kRigFile) + ": line 3, column 8: parse error: syntax error"));
}

TEST(RigJsonTest, RejectsDuplicateLedIds) {
  const std::string message = RigErrorAfter([](Json& json) { json["leds"][2]["id"] = 0; });
  ExpectFieldError(message, kRigFile, "leds[2].id", "0 is already used by leds[0]");
}

TEST(RigJsonTest, RejectsNegativeLedId) {
  ExpectFieldError(RigErrorAfter([](Json& json) { json["leds"][1]["id"] = -1; }), kRigFile, "leds[1].id",
                   "-1 must be >= 0");
}

TEST(RigJsonTest, RejectsOverflowingNumber) {
  // JSON has no inf; 1e999 is the nearest a file can get. Indented 6 and
  // after the key, it starts at column 13.
  Json json = Json::parse(RigDescriptionToJson(MakeTestRig()));
  json["leds"][1]["mu"] = 123456.5;
  std::string text = json.dump(2);
  text.replace(text.find("123456.5"), 8, "1e999");
  const std::string message = ErrorMessageOf([&] { RigDescriptionFromJson(text, kRigFile); });
  EXPECT_THAT(message, ::testing::MatchesRegex(std::string(kRigFile) +
                                               ": line [0-9]+, column 13: number overflow parsing '1e999'.*"));
}

TEST(RigJsonTest, CheckRejectsNegativeMu) {
  RigDescription rig = MakeTestRig();
  rig.leds[0].mu = -1;
  ExpectFieldError(ErrorMessageOf([&] { CheckRigDescription(rig, "rig"); }), "rig", "leds[0].mu",
                   "-1 must be finite and >= 0");
}

TEST(RigJsonTest, RejectsZeroQuaternion) {
  const std::string message = RigErrorAfter([](Json& json) {
    json["camera"]["cam_from_table"]["rotation"] = Json{{"w", 0}, {"x", 0}, {"y", 0}, {"z", 0}};
  });
  ExpectFieldError(message, kRigFile, "camera.cam_from_table.rotation", "must be a non-zero quaternion");
}

TEST(RigJsonTest, RejectsRigWithoutLeds) {
  ExpectFieldError(RigErrorAfter([](Json& json) { json["leds"] = Json::array(); }), kRigFile, "leds",
                   "must list at least one LED");
}

TEST(RigJsonTest, RejectsWrongVectorLength) {
  ExpectFieldError(RigErrorAfter([](Json& json) { json["leds"][0]["rgb_intensity"] = Json::array({1, 1}); }),
                   kRigFile, "leds[0].rgb_intensity", "must be an array of 3 numbers");
}

TEST(RigJsonTest, RejectsUnknownField) {
  ExpectFieldError(RigErrorAfter([](Json& json) { json["leds"][0]["intensity"] = 1; }), kRigFile,
                   "leds[0].intensity", "unknown field");
}

TEST(RigJsonTest, CheckRejectsTransformThatIsNotARotation) {
  RigDescription rig = MakeTestRig();
  rig.camera.cam_from_table.linear() *= 2.0;
  ExpectFieldError(ErrorMessageOf([&] { CheckRigDescription(rig, "rig"); }), "rig", "camera.cam_from_table.rotation",
                   "must be a rotation");
}

TEST(RigJsonTest, CheckRejectsNanPosition) {
  RigDescription rig = MakeTestRig();
  rig.leds[2].position_in_table_mm.y() = std::nan("");
  ExpectFieldError(ErrorMessageOf([&] { CheckRigDescription(rig, "rig"); }), "rig", "leds[2].position_in_table_mm",
                   "must be finite");
}

}  // namespace
}  // namespace scanbench
