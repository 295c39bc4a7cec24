// The simulated scan end to end through the controllers the CLI and GUI use:
// simulate -> DNG on disk -> decode -> develop -> solve -> maps and report.
#include <cstring>
#include <fstream>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

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

// A small simulated session in folder/session.
fs::path SimulateSmallSession(const TemporaryFolder& folder) {
  const fs::path session_dir = folder / "session";
  SimulateController(session_dir, SmallSimulation()).Run();
  return session_dir;
}

std::vector<fs::path> ResultFolders(const fs::path& session_dir) {
  std::vector<fs::path> folders;
  for (const auto& entry : fs::directory_iterator(session_dir / "results")) folders.push_back(entry.path());
  std::sort(folders.begin(), folders.end());
  return folders;
}

nlohmann::json ReadJson(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
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

// rounded_quantiles: the banded median and p95 are those of values held as
// floats (FloatErrorStatistics), the whole-frame ones rounded to float.
void ExpectSameStatistics(const ErrorStatistics& banded, const ErrorStatistics& whole, const std::string& what,
                          bool rounded_quantiles = false) {
  EXPECT_EQ(banded.num_pixels, whole.num_pixels) << what;
  EXPECT_EQ(banded.mean, whole.mean) << what;
  const auto rounded = [&](double value) { return rounded_quantiles ? double(static_cast<float>(value)) : value; };
  EXPECT_EQ(banded.median, rounded(whole.median)) << what;
  EXPECT_EQ(banded.percentile_95, rounded(whole.percentile_95)) << what;
  EXPECT_EQ(banded.max, whole.max) << what;
}

// The evaluate stage reads the truth in bands; every figure equals the
// whole-frame computation's exactly (the angles' and albedo errors' median and p95 rounded to float), on a ColorChecker session (whose patches
// are regions of the colour comparison) and a textile one, with bands that
// do not divide the height.
TEST(ScanControllersTest, BandedGroundTruthComparisonEqualsTheWholeFrameOne) {
  TemporaryFolder folder;
  for (const SampleKind sample : {SampleKind::kColorChecker, SampleKind::kTextile}) {
    const fs::path session_dir = folder / (sample == SampleKind::kTextile ? "textile" : "chart");
    SimulateOptions options = SmallSimulation();
    options.scene.sample = sample;
    SimulateController(session_dir, options).Run();
    const Session session = LoadSession(session_dir);
    const GroundTruthFiles& truth = *session.ground_truth;
    const ImageF truth_normals = ReadImageFloat(session_dir / truth.normal_file);
    const ImageF truth_albedo = ReadImageFloat(session_dir / truth.albedo_file);
    // A solution a little off the truth, some pixels unsolved.
    PhotometricSolution solution;
    solution.normal_in_table = truth_normals;
    solution.albedo = truth_albedo;
    solution.status = ImageU8(truth_normals.width(), truth_normals.height(), 1);
    std::mt19937 random(11);
    std::normal_distribution<float> noise(0.0f, 0.02f);
    for (size_t i = 0; i < solution.status.num_pixels(); ++i) {
      for (int c = 0; c < 3; ++c) {
        solution.normal_in_table.data()[3 * i + c] += noise(random);
        solution.albedo.data()[3 * i + c] *= 1.0f + noise(random);
      }
      if (i % 97 == 0) solution.status.data()[i] = static_cast<uint8_t>(PixelStatus::kNoSignal);
    }
    const ImageU8 stored_mask = ReadImageU8(session_dir / truth.mask_file);
    ImageU8 evaluated(solution.status.width(), solution.status.height(), 1);
    size_t unsolved = 0;
    for (size_t i = 0; i < evaluated.num_pixels(); ++i) {
      const bool on_sample = stored_mask.data()[i * stored_mask.channels()] > 127;
      evaluated.data()[i] = on_sample && solution.status.data()[i] == 0;
      unsolved += on_sample && solution.status.data()[i] != 0;
    }
    const AlbedoColorErrors whole_color = CompareAlbedoColor(solution.albedo, truth_albedo, evaluated);
    const ImageF whole_map = AngularErrorMapDegrees(solution.normal_in_table, truth_normals, evaluated);
    if (sample == SampleKind::kColorChecker) {
      EXPECT_GE(whole_color.chart_patches, 20) << "the patches must be regions";
    } else {
      EXPECT_TRUE(whole_color.regions.empty());
    }
    for (const int band_rows : {7, kEvaluationBandRows}) {
      SCOPED_TRACE(band_rows);
      const GroundTruthComparison banded = CompareWithGroundTruth(session_dir, truth, solution, 2, band_rows);
      ExpectSameStatistics(banded.normal_error_deg,
                           AngularErrorDegrees(solution.normal_in_table, truth_normals, evaluated), "normals",
                           /*rounded_quantiles=*/true);
      ExpectSameStatistics(banded.albedo_error, AbsoluteError(solution.albedo, truth_albedo, evaluated), "albedo",
                           /*rounded_quantiles=*/true);
      ExpectSameStatistics(banded.albedo_color_error.delta_e, whole_color.delta_e, "CIEDE2000");
      EXPECT_EQ(banded.albedo_color_error.ReportJson(), whole_color.ReportJson());
      EXPECT_EQ(banded.unsolved_on_sample, unsolved);
      ASSERT_TRUE(banded.angular_error_deg.SameSize(whole_map));
      EXPECT_TRUE(std::equal(whole_map.data(), whole_map.data() + whole_map.size(), banded.angular_error_deg.data()));
    }
  }
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

TEST(ScanControllersTest, ResultFolderHoldsMapsAndReport) {
  TemporaryFolder folder;
  const fs::path session_dir = SimulateSmallSession(folder);
  SolveController solve(session_dir, SolveOptions());
  solve.Run();

  const fs::path result = solve.summary().result_dir;
  ASSERT_EQ(ResultFolders(session_dir), std::vector<fs::path>{result});
  for (const char* name : {"normal.exr", "normal.png", "albedo.exr", "albedo_srgb.png", "status.png",
                           "solved_mask.png", "confidence.exr", "angular_error_deg.exr", "report.json",
                           "summary.txt"}) {
    EXPECT_TRUE(fs::is_regular_file(result / name)) << name;
  }
  const ImageF normals = ReadImageFloat(result / "normal.exr");
  EXPECT_EQ(normals.width(), 400);
  EXPECT_EQ(normals.channels(), 3);
  EXPECT_EQ(ReadImageFileInfo(result / "normal.exr").bits_per_sample, 16);  // half by default
  // The 16-bit PNG encodes the same normals: (n + 1) / 2, from the float
  // normals; the EXR's half holds them within 2^-12 (at 0.5 .. 1).
  const ImageU16 encoded = ReadImageU16(result / "normal.png");
  EXPECT_NEAR(encoded(200, 132, 2) / 65535.0 * 2 - 1, normals(200, 132, 2), 1.0 / 4096 + 1e-5);

  // The bytes of every file but the two reports, each and in total.
  const nlohmann::json bytes = ReadJson(result / "report.json")["bytes_written"];
  EXPECT_EQ(bytes["exr_encoding"], "half, piz");
  uintmax_t total = 0;
  for (const auto& entry : fs::directory_iterator(result)) {
    const std::string name = entry.path().filename().string();
    if (name == "report.json" || name == "summary.txt") continue;
    EXPECT_EQ(bytes["files"][name].get<uintmax_t>(), entry.file_size()) << name;
    total += entry.file_size();
  }
  EXPECT_EQ(bytes["files"].size(), 9u);  // 7 maps, specular.exr, angular_error_deg.exr
  EXPECT_EQ(bytes["total"].get<uintmax_t>(), total);
  EXPECT_EQ(solve.summary().TotalBytesWritten(), total);
  std::ifstream summary_file(result / "summary.txt");
  const std::string summary_text((std::istreambuf_iterator<char>(summary_file)), std::istreambuf_iterator<char>());
  EXPECT_THAT(summary_text, HasSubstr("bytes written (half, piz EXR): albedo.exr "));
  EXPECT_THAT(summary_text, HasSubstr(" total " + std::to_string(total) + " ("));

  // solve --float32-maps: the full-precision files, larger, the PNGs identical.
  SolveOptions float32;
  float32.float32_maps = true;
  SolveController full(session_dir, float32);
  full.Run();
  const fs::path full_result = full.summary().result_dir;
  EXPECT_EQ(ReadImageFileInfo(full_result / "normal.exr").bits_per_sample, 32);
  EXPECT_EQ(ReadImageFileInfo(full_result / "confidence.exr").bits_per_sample, 32);
  const ImageF full_normals = ReadImageFloat(full_result / "normal.exr");
  EXPECT_NEAR(encoded(200, 132, 2) / 65535.0 * 2 - 1, full_normals(200, 132, 2), 1e-4);
  EXPECT_EQ(Sha256HexOfFile(full_result / "normal.png"), Sha256HexOfFile(result / "normal.png"));
  EXPECT_GT(full.summary().TotalBytesWritten(), total);
  EXPECT_EQ(ReadJson(full_result / "report.json")["bytes_written"]["exr_encoding"], "float32, zip");
  EXPECT_NE(full.summary().inputs_fingerprint, solve.summary().inputs_fingerprint);

  const nlohmann::json report = ReadJson(result / "report.json");
  EXPECT_EQ(report["solver"]["method"], "adaptive");
  EXPECT_EQ(report["session"]["leds"], 10);
  EXPECT_GT(report["timings_s"]["solve"].get<double>(), 0.0);
  for (const char* stage : {"load", "decode", "light_field", "solve", "evaluate", "write_maps"}) {
    EXPECT_TRUE(report["timings_s"].contains(stage)) << stage;
  }
  const double mean = report["ground_truth"]["normal_angular_error_deg"]["mean"];
  EXPECT_DOUBLE_EQ(mean, solve.summary().normal_error_deg->mean);
  // A small capture has fewer pixels per thread: looser than the main job, still close.
  EXPECT_LT(mean, 3.0);
  EXPECT_THAT(report["result"]["message"].get<std::string>(), HasSubstr("success"));
}

TEST(ScanControllersTest, ResolveWritesANewResultBesideTheOld) {
  TemporaryFolder folder;
  const fs::path session_dir = SimulateSmallSession(folder);
  SolveController first(session_dir, SolveOptions());
  first.Run();
  const std::string first_report = Sha256HexOfFile(first.summary().result_dir / "report.json");
  SolveOptions bilinear;
  bilinear.develop.demosaic = RawDevelopOptions::Demosaic::kBilinear;
  bilinear.run_label = "bilinear";
  SolveController second(session_dir, bilinear);
  second.Run();
  EXPECT_NE(first.summary().result_dir, second.summary().result_dir);
  EXPECT_EQ(ResultFolders(session_dir).size(), 2u);
  EXPECT_EQ(Sha256HexOfFile(first.summary().result_dir / "report.json"), first_report) << "old result untouched";
  EXPECT_THAT(second.summary().result_dir.filename().string(), HasSubstr("bilinear"));
}

// Issue #13: the Bayer-domain option solves per raw pixel and says so in the
// summary, report.json and the inputs fingerprint (batch must not skip it);
// the default blends the demosaiced and Bayer-domain normals, which the
// Bayer-domain option does not.
TEST(ScanControllersTest, BayerDomainSolveIsItsOwnResult) {
  TemporaryFolder folder;
  const fs::path session_dir = SimulateSmallSession(folder);
  SolveController demosaiced(session_dir, SolveOptions());
  demosaiced.Run();
  SolveOptions options;
  options.bayer_domain = true;
  options.run_label = "bayer";
  SolveController bayer(session_dir, options);
  bayer.Run();
  const SolveSummary& summary = bayer.summary();
  EXPECT_TRUE(summary.solver.bayer_domain);
  EXPECT_FALSE(demosaiced.summary().solver.bayer_domain);
  ASSERT_TRUE(summary.normal_error_deg.has_value());
  EXPECT_LE(summary.normal_error_deg->mean, 1.0);
  EXPECT_EQ(summary.unsolved_on_sample, 0u);
  EXPECT_NE(summary.inputs_fingerprint, demosaiced.summary().inputs_fingerprint);
  const nlohmann::json report = ReadJson(summary.result_dir / "report.json");
  EXPECT_EQ(report.at("develop").at("bayer_domain"), true);
  EXPECT_EQ(report.at("develop").at("bayer_blend"), false);
  EXPECT_EQ(summary.solver.pixels_bayer_blended, 0u);
  EXPECT_GT(demosaiced.summary().solver.pixels_bayer_blended, 0u);
  EXPECT_EQ(ReadJson(demosaiced.summary().result_dir / "report.json").at("develop").at("bayer_blend"), true);
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

TEST(ScanControllersTest, CancelledSolveLeavesNoResultFolder) {
  TemporaryFolder folder;
  const fs::path session_dir = SimulateSmallSession(folder);
  SolveController solve(session_dir, SolveOptions());
  solve.SetProgressCallback([&](const ProgressReport& report) {
    if (report.stage == "solve") solve.RequestStop();
  });
  EXPECT_THROW(solve.Run(), Cancelled);
  EXPECT_TRUE(ResultFolders(session_dir).empty());
}

TEST(ScanControllersTest, CorruptFrameIsReportedByName) {
  TemporaryFolder folder;
  const fs::path session_dir = SimulateSmallSession(folder);
  // Cut the fourth LED frame short, as a failed copy would.
  const fs::path frame = session_dir / "frames" / "led_03.dng";
  std::vector<uint8_t> bytes = ReadFileBytes(frame);
  bytes.resize(bytes.size() / 2);
  fs::remove(frame);
  WriteFileAtomic(frame, bytes, OverwritePolicy::kRefuse);

  // The checksum catches it first ...
  EXPECT_THAT([&] { SolveController(session_dir, SolveOptions()).Run(); },
              ::testing::ThrowsMessage<SessionError>(HasSubstr("led_03.dng")));
  // ... and the RAW validation when checksums are skipped.
  SolveOptions unverified;
  unverified.verify_checksums = false;
  EXPECT_THAT([&] { SolveController(session_dir, unverified).Run(); },
              ::testing::ThrowsMessage<std::runtime_error>(AllOf(HasSubstr("led_03.dng"), HasSubstr("truncated"))));
  EXPECT_TRUE(ResultFolders(session_dir).empty());
}

TEST(ScanControllersTest, IncompleteSessionIsNotSolved) {
  TemporaryFolder folder;
  const fs::path session_dir = folder / "session";
  SimulateController interrupted(session_dir, SmallSimulation());
  interrupted.SetProgressCallback([&](const ProgressReport& report) {
    if (report.stage == "simulate") interrupted.RequestStop();
  });
  EXPECT_THROW(interrupted.Run(), Cancelled);
  EXPECT_THAT([&] { SolveController(session_dir, SolveOptions()).Run(); },
              ::testing::ThrowsMessage<SessionError>(HasSubstr("capture_complete")));
}

TEST(ScanControllersTest, BadOptionsAreRejectedBeforeWork) {
  TemporaryFolder folder;
  SolveOptions options;
  options.run_label = "../escape";
  EXPECT_THAT([&] { SolveController(folder.path(), options).Run(); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("run_label")));
  SimulateOptions simulate = SmallSimulation();
  simulate.rig.width = -5;
  EXPECT_THROW(SimulateController(folder / "s", simulate).Run(), std::invalid_argument);
  EXPECT_FALSE(fs::exists(folder / "s"));
}

}  // namespace
}  // namespace scanbench
