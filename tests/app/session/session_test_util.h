// Builders shared by the app/session tests: a rig and a session whose numbers
// are awkward on purpose (thirds, tiny, negative zero) to catch lossy JSON.
#pragma once

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/session/session.h"
#include "tests/util/temporary_folder.h"

namespace scanbench::testing_util {

using ::scanbench::testing::TemporaryFolder;

inline RigDescription MakeTestRig(int num_leds = 3) {
  RigDescription rig;
  rig.name = "bench-a \xc3\xa9";  // UTF-8 survives
  CameraIntrinsics& k = rig.camera.intrinsics;
  k.width = 6000;
  k.height = 4000;
  k.fx = 4321.123456789012;
  k.fy = 4321.0 + 1.0 / 3.0;
  k.cx = 2999.5 + 1.0 / 3.0;
  k.cy = 1999.5 - 1.0 / 7.0;
  k.k1 = -0.1234567890123457;
  k.k2 = 1e-300;
  k.k3 = 5e-324;  // smallest subnormal
  k.p1 = -0.0;
  k.p2 = 0.1 + 0.2;
  // Looking down at the table from 600 mm, slightly tilted.
  const Eigen::Quaterniond tilt(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  const Eigen::Quaterniond down(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()));
  rig.camera.cam_from_table.linear() = (tilt * down).toRotationMatrix();
  rig.camera.cam_from_table.translation() = Eigen::Vector3d(1.0 / 3.0, -2.5, 600.0 + 1e-9);
  for (int i = 0; i < num_leds; ++i) {
    LedDescription led;
    led.id = i;
    const double angle = 2 * M_PI * i / num_leds;
    led.position_in_table_mm = Eigen::Vector3d(300 * std::cos(angle), 300 * std::sin(angle), 250.0 / 3.0);
    led.axis_in_table = (-led.position_in_table_mm).normalized();
    led.mu = 1.5 + i / 7.0;
    led.rgb_intensity = Eigen::Vector3d(0.1 * (i + 1), 0.2, 0.30000000000000004);
    rig.leds.push_back(led);
  }
  return rig;
}

// A session as capture starts: no frames yet.
inline Session MakeTestSession(int num_leds = 3) {
  Session session;
  session.sample_name = "denim-0042";
  session.notes = "washed twice; \"quoted\"\nsecond line";
  session.created = "2024-05-01T12:34:56.789Z";
  session.software_version = "0.1.0";
  session.rig = MakeTestRig(num_leds);
  session.camera.make = "Canon";
  session.camera.model = "EOS R5";
  session.camera.serial = "0123456789";
  session.camera.lens = "RF 100mm F2.8 L MACRO IS USM";
  session.camera.iso = 100;
  session.camera.exposure_time_s = 1.0 / 60.0;
  session.camera.f_number = 5.6;
  session.camera.width = 6000;
  session.camera.height = 4000;
  return session;
}

inline FrameRecord MakeFrameRecord(FrameKind kind, int led_index) {
  FrameRecord record;
  record.kind = kind;
  record.led_index = led_index;
  char name[64];
  if (kind == FrameKind::kDark) {
    std::snprintf(name, sizeof(name), "frames/dark.dng");
  } else {
    std::snprintf(name, sizeof(name), "frames/led_%02d.dng", led_index);
  }
  record.file = name;
  char time[64];
  std::snprintf(time, sizeof(time), "2024-05-01T12:35:%02d.250Z", led_index + 1);
  record.capture_time = time;
  record.exposure_time_s = 1.0 / 60.0;
  record.width = 6000;
  record.height = 4000;
  return record;
}

// Stand-in for a RAW file: a few hundred distinct bytes per seed.
inline std::vector<uint8_t> FakeRawBytes(int seed) {
  std::mt19937 rng(static_cast<unsigned>(seed) + 1);
  std::vector<uint8_t> bytes(300 + seed);
  for (uint8_t& byte : bytes) byte = static_cast<uint8_t>(rng());
  return bytes;
}

inline std::string ReadText(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}


inline void ExpectSameBits(double expected, double actual, const std::string& what) {
  EXPECT_EQ(std::bit_cast<uint64_t>(expected), std::bit_cast<uint64_t>(actual))
      << what << ": expected " << expected << ", got " << actual;
}

inline void ExpectSameBits(const Eigen::Vector3d& expected, const Eigen::Vector3d& actual, const std::string& what) {
  for (int i = 0; i < 3; ++i) ExpectSameBits(expected[i], actual[i], what + "[" + std::to_string(i) + "]");
}

// Every double bit for bit, except the rotation: it is stored as a quaternion,
// and matrix -> quaternion -> matrix is exact only to a few ulp.
inline void ExpectSameRig(const RigDescription& expected, const RigDescription& actual) {
  EXPECT_EQ(expected.name, actual.name);
  const CameraIntrinsics& a = expected.camera.intrinsics;
  const CameraIntrinsics& b = actual.camera.intrinsics;
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  ExpectSameBits(a.fx, b.fx, "fx");
  ExpectSameBits(a.fy, b.fy, "fy");
  ExpectSameBits(a.cx, b.cx, "cx");
  ExpectSameBits(a.cy, b.cy, "cy");
  ExpectSameBits(a.k1, b.k1, "k1");
  ExpectSameBits(a.k2, b.k2, "k2");
  ExpectSameBits(a.k3, b.k3, "k3");
  ExpectSameBits(a.p1, b.p1, "p1");
  ExpectSameBits(a.p2, b.p2, "p2");
  EXPECT_LE((expected.camera.cam_from_table.linear() - actual.camera.cam_from_table.linear()).cwiseAbs().maxCoeff(),
            1e-15);
  ExpectSameBits(expected.camera.cam_from_table.translation(), actual.camera.cam_from_table.translation(),
                 "translation");
  ASSERT_EQ(expected.leds.size(), actual.leds.size());
  for (size_t i = 0; i < expected.leds.size(); ++i) {
    const std::string led = "leds[" + std::to_string(i) + "].";
    EXPECT_EQ(expected.leds[i].id, actual.leds[i].id);
    ExpectSameBits(expected.leds[i].position_in_table_mm, actual.leds[i].position_in_table_mm, led + "position");
    ExpectSameBits(expected.leds[i].axis_in_table, actual.leds[i].axis_in_table, led + "axis");
    ExpectSameBits(expected.leds[i].mu, actual.leds[i].mu, led + "mu");
    ExpectSameBits(expected.leds[i].rgb_intensity, actual.leds[i].rgb_intensity, led + "rgb_intensity");
  }
}

inline void ExpectSameSession(const Session& expected, const Session& actual) {
  EXPECT_EQ(expected.schema_version, actual.schema_version);
  EXPECT_EQ(expected.sample_name, actual.sample_name);
  EXPECT_EQ(expected.notes, actual.notes);
  EXPECT_EQ(expected.created, actual.created);
  EXPECT_EQ(expected.software_version, actual.software_version);
  EXPECT_EQ(expected.capture_complete, actual.capture_complete);
  ExpectSameRig(expected.rig, actual.rig);
  EXPECT_EQ(expected.camera.make, actual.camera.make);
  EXPECT_EQ(expected.camera.model, actual.camera.model);
  EXPECT_EQ(expected.camera.serial, actual.camera.serial);
  EXPECT_EQ(expected.camera.lens, actual.camera.lens);
  ExpectSameBits(expected.camera.iso, actual.camera.iso, "camera.iso");
  ExpectSameBits(expected.camera.exposure_time_s, actual.camera.exposure_time_s, "camera.exposure_time_s");
  ExpectSameBits(expected.camera.f_number, actual.camera.f_number, "camera.f_number");
  EXPECT_EQ(expected.camera.width, actual.camera.width);
  EXPECT_EQ(expected.camera.height, actual.camera.height);
  ASSERT_EQ(expected.frames.size(), actual.frames.size());
  for (size_t i = 0; i < expected.frames.size(); ++i) {
    const FrameRecord& a = expected.frames[i];
    const FrameRecord& b = actual.frames[i];
    EXPECT_EQ(a.kind, b.kind);
    EXPECT_EQ(a.led_index, b.led_index);
    EXPECT_EQ(a.file, b.file);
    EXPECT_EQ(a.sha256, b.sha256);
    EXPECT_EQ(a.capture_time, b.capture_time);
    ExpectSameBits(a.exposure_time_s, b.exposure_time_s, "frames[" + std::to_string(i) + "].exposure_time_s");
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
  }
  ASSERT_EQ(expected.simulation.has_value(), actual.simulation.has_value());
  if (expected.simulation) {
    const SimulatedSceneRecord& a = *expected.simulation;
    const SimulatedSceneRecord& b = *actual.simulation;
    EXPECT_EQ(a.sample, b.sample);
    EXPECT_EQ(a.material, b.material);
    EXPECT_EQ(a.scene_seed, b.scene_seed);
    ExpectSameBits(a.warp_pitch_mm, b.warp_pitch_mm, "simulation.warp_pitch_mm");
    ExpectSameBits(a.weft_pitch_mm, b.weft_pitch_mm, "simulation.weft_pitch_mm");
    EXPECT_EQ(a.noise_seed, b.noise_seed);
    EXPECT_EQ(a.noise, b.noise);
    ExpectSameBits(a.fold_amplitude_mm, b.fold_amplitude_mm, "simulation.fold_amplitude_mm");
    EXPECT_EQ(a.cast_shadows, b.cast_shadows);
  }
  ASSERT_EQ(expected.ground_truth.has_value(), actual.ground_truth.has_value());
  if (expected.ground_truth) {
    const GroundTruthFiles& a = *expected.ground_truth;
    const GroundTruthFiles& b = *actual.ground_truth;
    EXPECT_EQ(a.normal_file, b.normal_file);
    EXPECT_EQ(a.normal_sha256, b.normal_sha256);
    EXPECT_EQ(a.albedo_file, b.albedo_file);
    EXPECT_EQ(a.albedo_sha256, b.albedo_sha256);
    EXPECT_EQ(a.height_file, b.height_file);
    EXPECT_EQ(a.height_sha256, b.height_sha256);
    EXPECT_EQ(a.mask_file, b.mask_file);
    EXPECT_EQ(a.mask_sha256, b.mask_sha256);
    ExpectSameBits(a.mm_per_pixel, b.mm_per_pixel, "ground_truth.mm_per_pixel");
  }
}

// The message of the SessionError that `function` throws; fails the test if none.
template <typename Function>
std::string ErrorMessageOf(Function&& function) {
  try {
    function();
  } catch (const SessionError& error) {
    return error.what();
  } catch (const std::exception& error) {
    ADD_FAILURE() << "expected SessionError, got another exception: " << error.what();
    return error.what();
  }
  ADD_FAILURE() << "expected SessionError, nothing was thrown";
  return "";
}

// "<file>: <field>: ...<rule>..."
inline void ExpectFieldError(const std::string& message, const std::string& file, const std::string& field,
                             const std::string& rule) {
  EXPECT_THAT(message, ::testing::StartsWith(file + ": " + field + ": ")) << message;
  EXPECT_THAT(message, ::testing::HasSubstr(rule)) << message;
}

}  // namespace scanbench::testing_util
