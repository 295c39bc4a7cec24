// The simulated scan end to end through the controllers the CLI and GUI use:
// simulate -> DNG on disk -> decode -> develop -> solve -> maps and report.
// The solve job's own tests (result folders, cancels, routes) are in
// solve_controller_test.cc.
#include <cstring>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/controllers/simulate_controller.h"
#include "app/controllers/solve_controller.h"
#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "app/io/raw_decoder.h"
#include "app/sim/sensor_color.h"
#include "calibration/camera_model.h"
#include "calibration/color_checker.h"
#include "app/session/session.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::TemporaryFolder;

SimulateOptions SmallSimulation() {
  SimulateOptions options;
  options.rig.width = 400;
  options.rig.height = 264;
  return options;
}

// The accuracy target, at the default size and scene of the main job.
TEST(ScanControllersTest, DefaultSceneSolvesWithinOneDegree) {
  TemporaryFolder folder;
  const fs::path session_dir = folder / "session";
  SimulateController simulate(session_dir, SimulateOptions());
  simulate.Run();
  EXPECT_EQ(simulate.summary().frames_written, 11);

  SolveController solve(session_dir, SolveOptions());
  solve.Run();
  const SolveSummary& summary = solve.summary();
  ASSERT_TRUE(summary.normal_error_deg.has_value());
  EXPECT_LE(summary.normal_error_deg->mean, 1.0);
  EXPECT_LE(summary.normal_error_deg->median, 0.6);
  // The default camera is the spectral D5100 (issue #12): without a colour
  // calibration the solve takes the DNG's camera matrix to linear Rec.709 (0.016
  // measured against the Rec.709 ground truth; 0.048 as white-balanced camera
  // RGB; 0.005 with the old sRGB-primaries camera, whose frames
  // srgb_primaries_camera_test checks).
  EXPECT_EQ(summary.albedo_color.source, AlbedoColorOptions::Source::kCameraMatrix);
  EXPECT_LE(summary.albedo_error->mean, 0.025);
  EXPECT_GT(summary.normal_error_deg->num_pixels, 500000u) << "most of the sample must be evaluated";
  EXPECT_EQ(summary.unsolved_on_sample, 0u);
  EXPECT_EQ(summary.clipped_samples, 0u);
}

// The ground truth's EXRs are 32-bit float without compression (issue #14:
// every solve and export decodes them), each value exactly the rendered one.
TEST(ScanControllersTest, GroundTruthIsUncompressedFloatWithTheRenderedValues) {
  TemporaryFolder folder;
  const SimulateOptions options = SmallSimulation();
  const fs::path session_dir = folder / "session";
  SimulateController(session_dir, options).Run();
  const Session session = LoadSession(session_dir);
  ASSERT_TRUE(session.ground_truth.has_value());
  const SimulatedRig rig(options.rig, TextileScene(options.scene),
                         MakeDefaultSimulatedRig(options.rig.width, options.rig.height, options.rig.color));
  const GroundTruthMaps rendered = rig.RenderGroundTruth();
  const GroundTruthFiles& truth = *session.ground_truth;
  for (const auto& [file, image] : {std::pair{truth.normal_file, &rendered.normal_in_table},
                                    std::pair{truth.albedo_file, &rendered.albedo},
                                    std::pair{truth.height_file, &rendered.height_mm}}) {
    SCOPED_TRACE(file);
    const ImageFileInfo info = ReadImageFileInfo(session_dir / file);
    EXPECT_EQ(info.compression, "none");
    EXPECT_TRUE(info.is_float);
    EXPECT_EQ(info.bits_per_sample, 32);
    const ImageF read = ReadImageFloat(session_dir / file);
    ASSERT_EQ(read.size(), image->size());
    EXPECT_EQ(std::memcmp(read.data(), image->data(), read.size() * sizeof(float)), 0);
  }
}

// Issue #12: the ColorChecker sample's ground truth is each patch's linear
// Rec.709, and every DNG carries the simulated camera's colour matrix.
TEST(ScanControllersTest, ColorCheckerSessionHasPatchTruthAndTheCamerasColorMatrix) {
  TemporaryFolder folder;
  const fs::path session_dir = folder / "session";
  SimulateOptions options = SmallSimulation();
  options.scene.sample = SampleKind::kColorChecker;
  SimulateController(session_dir, options).Run();
  const Session session = LoadSession(session_dir);
  EXPECT_EQ(session.camera.model, "Simulated D5100");
  ASSERT_TRUE(session.ground_truth.has_value());

  const ImageF albedo = ReadImageFloat(session_dir / session.ground_truth->albedo_file);
  const RigDescription rig = MakeDefaultSimulatedRig(options.rig.width, options.rig.height);
  for (int k = 0; k < 24; ++k) {
    // The patch centre on the card's face (0.4 mm above the table).
    const Eigen::Vector3d centre((k % 6 - 2.5) * 20, (1.5 - k / 6) * 20, options.scene.chart_thickness_mm);
    const Eigen::Vector2d pixel = ProjectToPixel(rig.camera.intrinsics, rig.camera.cam_from_table * centre);
    const int x = static_cast<int>(std::lround(pixel.x())), y = static_cast<int>(std::lround(pixel.y()));
    for (int c = 0; c < 3; ++c) {
      EXPECT_FLOAT_EQ(albedo(x, y, c), static_cast<float>(ColorCheckerClassic()[k].linear_rec709[c]))
          << ColorCheckerClassic()[k].name << " channel " << c;
    }
  }

  const DecodedRaw frame = DecodeRawFileWithInfo(session_dir / session.frames[1].file);
  ASSERT_TRUE(frame.camera_from_xyz.has_value());
  EXPECT_TRUE(frame.camera_from_xyz->isApprox(SimulatedCameraFromXyzD65(SensorColorModel::kNikonD5100), 1e-4))
      << *frame.camera_from_xyz;
  EXPECT_TRUE(frame.as_shot_neutral.isApprox(SimulatedAsShotNeutral(SensorColorModel::kNikonD5100), 1e-4))
      << frame.as_shot_neutral.transpose();
}

// Starts simulating into session_dir and stops it a third of the way: an
// interrupted session with a few frames on disk.
void InterruptSimulation(const fs::path& session_dir, const SimulateOptions& options) {
  SimulateController first(session_dir, options);
  first.SetProgressCallback([&](const ProgressReport& report) {
    if (report.stage == "simulate" && report.fraction > 0.3) first.RequestStop();
  });
  EXPECT_THROW(first.Run(), Cancelled);
}

// simulate, like capture, refuses a session another writer holds, before
// rendering anything, and runs once it is free.
TEST(ScanControllersTest, SimulateIntoAHeldSessionIsRefusedUpFront) {
  TemporaryFolder folder;
  const fs::path session_dir = folder / "session";
  {
    FolderLock other_writer(session_dir);
    EXPECT_THAT([&] { SimulateController(session_dir, SmallSimulation()).Run(); },
                ::testing::ThrowsMessage<FolderBusyError>(HasSubstr(session_dir.string() + ": in use by another")));
    EXPECT_FALSE(fs::exists(session_dir / "session.json"));
  }
  SimulateController(session_dir, SmallSimulation()).Run();
  EXPECT_TRUE(LoadSession(session_dir).capture_complete);
}

TEST(ScanControllersTest, ResumingWithAnotherCameraColorIsRefused) {
  TemporaryFolder folder;
  const fs::path session_dir = folder / "session";
  SimulateOptions options = SmallSimulation();
  options.rig.color = SensorColorModel::kSrgbPrimaries;
  InterruptSimulation(session_dir, options);
  EXPECT_EQ(LoadSession(session_dir).camera.model, "Simulated D5100 (sRGB primaries)");
  options.rig.color = SensorColorModel::kNikonD5100;
  EXPECT_THAT([&] { SimulateController(session_dir, options).Run(); },
              ::testing::ThrowsMessage<SessionError>(HasSubstr("camera.model")));
}

// session.json records the scene (material, sample, seeds, pitches, noise,
// shadows); resuming with another material is refused, naming both values.
TEST(ScanControllersTest, ResumingWithAnotherMaterialIsRefused) {
  TemporaryFolder folder;
  const fs::path session_dir = folder / "session";
  SimulateOptions options = SmallSimulation();
  options.scene.material = SurfaceMaterial::kSatin;
  InterruptSimulation(session_dir, options);
  const Session partial = LoadSession(session_dir);
  ASSERT_TRUE(partial.simulation.has_value());
  EXPECT_EQ(partial.simulation->material, "satin");
  EXPECT_EQ(partial.simulation->sample, "twill");
  options.scene.material = SurfaceMaterial::kCloth;
  EXPECT_THAT([&] { SimulateController(session_dir, options).Run(); },
              ::testing::ThrowsMessage<SessionError>(::testing::AllOf(
                  HasSubstr("simulation.material"), HasSubstr("recorded 'satin'"), HasSubstr("requested 'cloth'"))));
  options.scene.material = SurfaceMaterial::kSatin;
  options.scene.warp_pitch_mm = 1.2;
  EXPECT_THAT([&] { SimulateController(session_dir, options).Run(); },
              ::testing::ThrowsMessage<SessionError>(HasSubstr("simulation.warp_pitch_mm: recorded '2.4'")));
  options.scene.warp_pitch_mm = SimulateOptions().scene.warp_pitch_mm;
  SimulateController resumed(session_dir, options);
  resumed.Run();
  EXPECT_GT(resumed.summary().frames_resumed, 0);
  EXPECT_EQ(LoadSession(session_dir).simulation->material, "satin");
}

TEST(ScanControllersTest, InterruptedSimulationResumesWhereItStopped) {
  TemporaryFolder folder;
  const fs::path session_dir = folder / "session";
  SimulateController interrupted(session_dir, SmallSimulation());
  // Stop once the fourth frame starts rendering: three frames are on disk.
  interrupted.SetProgressCallback([&](const ProgressReport& report) {
    if (report.stage == "simulate" && report.fraction > 3.2 / 11) interrupted.RequestStop();
  });
  EXPECT_THROW(interrupted.Run(), Cancelled);
  const Session partial = LoadSession(session_dir);
  EXPECT_FALSE(partial.capture_complete);
  ASSERT_EQ(partial.frames.size(), 3u);
  const std::string dark_sha = partial.frames[0].sha256;

  SimulateController resumed(session_dir, SmallSimulation());
  resumed.Run();
  EXPECT_EQ(resumed.summary().frames_resumed, 3);
  EXPECT_EQ(resumed.summary().frames_written, 8);
  const Session complete = LoadSession(session_dir);
  EXPECT_TRUE(complete.capture_complete);
  EXPECT_EQ(complete.frames.size(), 11u);
  EXPECT_EQ(complete.frames[0].sha256, dark_sha) << "frames on disk are never rewritten";

  // A complete session is never simulated over.
  SimulateController again(session_dir, SmallSimulation());
  EXPECT_THAT([&] { again.Run(); }, ::testing::ThrowsMessage<SessionError>(HasSubstr("complete")));
}

TEST(ScanControllersTest, BadSimulateOptionsAreRejectedBeforeWork) {
  TemporaryFolder folder;
  SimulateOptions simulate = SmallSimulation();
  simulate.rig.width = -5;
  EXPECT_THROW(SimulateController(folder / "s", simulate).Run(), std::invalid_argument);
  EXPECT_FALSE(fs::exists(folder / "s"));
}

}  // namespace
}  // namespace scanbench
