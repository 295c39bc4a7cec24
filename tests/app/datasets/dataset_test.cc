// Dataset folders (DiLiGenT and the LUCES-style near-field layout): reading,
// solving, the controller's files, and the DiLiGenT reproduction when the
// data are present (../shared/data/diligent beside the repository).
#include <cmath>
#include <fstream>

#include <Eigen/Dense>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/controllers/dataset_controller.h"
#include "app/controllers/solver_report_controller.h"
#include "app/io/dataset_io.h"
#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "solver/cloth_material.h"
#include "solver/synthetic_scene.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using Method = PhotometricSolverOptions::Method;
using ::testing::HasSubstr;
using testing::TemporaryFolder;

void WriteText(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

ImageU16 ToU16(const ImageF& image) {
  ImageU16 out(image.width(), image.height(), image.channels());
  for (size_t i = 0; i < image.size(); ++i) {
    out.data()[i] = static_cast<uint16_t>(std::lround(std::clamp(double(image.data()[i]), 0.0, 1.0) * 65535));
  }
  return out;
}

void WriteMask(const fs::path& path, const ImageU8& mask) {
  ImageU8 out(mask.width(), mask.height(), 1);
  for (size_t i = 0; i < mask.size(); ++i) out.data()[i] = mask.data()[i] ? 255 : 0;
  WritePng(path, out, OverwritePolicy::kRefuse);
}

// A DiLiGenT-format folder of a synthetic sphere: 16-bit images, text files,
// mask and Normal_gt.mat (MATLAB layout).
void WriteDiligentFolder(const fs::path& folder, const SyntheticScene& scene,
                         const std::vector<Eigen::Vector3d>& dirs, const std::vector<Eigen::Vector3d>& intensities) {
  fs::create_directories(folder);
  std::string names, directions, strengths;
  for (size_t k = 0; k < scene.images.size(); ++k) {
    char name[32] = {};
    std::snprintf(name, sizeof(name), "%03zu.png", k + 1);
    WritePng(folder / name, ToU16(scene.images[k]), OverwritePolicy::kRefuse);
    names += std::string(name) + "\n";
    directions += std::to_string(dirs[k].x()) + " " + std::to_string(dirs[k].y()) + " " + std::to_string(dirs[k].z()) + "\n";
    strengths += std::to_string(intensities[k].x()) + " " + std::to_string(intensities[k].y()) + " " +
                 std::to_string(intensities[k].z()) + "\n";
  }
  WriteText(folder / "filenames.txt", names);
  WriteText(folder / "light_directions.txt", directions);
  WriteText(folder / "light_intensities.txt", strengths);
  WriteMask(folder / "mask.png", scene.object);
  WriteMatImage(folder / "Normal_gt.mat", "Normal_gt", scene.normal_in_table);
}

SyntheticScene DistantSphere(std::vector<Eigen::Vector3d>* dirs, std::vector<Eigen::Vector3d>* intensities) {
  SyntheticSceneOptions options;
  options.width = 64;
  options.height = 48;
  options.num_lights = 12;
  SyntheticScene scene = MakeSyntheticScene(options);
  *dirs = RingLightDirections(12, 30, 60);
  intensities->clear();
  std::vector<float> d(36), in(36);
  scene.light_field->Evaluate(0, 0, d.data(), in.data());
  for (int k = 0; k < 12; ++k) intensities->emplace_back(in[3 * k], in[3 * k + 1], in[3 * k + 2]);
  return scene;
}

TEST(DatasetIoTest, MatImageRoundTripsInMatlabLayout) {
  TemporaryFolder folder;
  ImageF image(5, 3, 3);
  for (size_t i = 0; i < image.size(); ++i) image.data()[i] = 0.25f * float(i) - 3;
  WriteMatImage(folder / "x.mat", "Normal_gt", image);
  const ImageF back = ReadMatImage3(folder / "x.mat", "Normal_gt");
  ASSERT_EQ(back.width(), 5);
  ASSERT_EQ(back.height(), 3);
  for (size_t i = 0; i < image.size(); ++i) ASSERT_EQ(back.data()[i], image.data()[i]);
  EXPECT_THAT([&] { ReadMatImage3(folder / "x.mat", "Other"); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("has no variable 'Other'")));
  WriteMatImage(folder / "y.mat", "Normal_gt", ImageF(4, 4, 2));
  EXPECT_THAT([&] { ReadMatImage3(folder / "y.mat", "Normal_gt"); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("is 4x4x2; height x width x 3 required")));
}

TEST(DatasetIoTest, DiligentFolderSolvesToItsGroundTruth) {
  TemporaryFolder folder;
  std::vector<Eigen::Vector3d> dirs, intensities;
  const SyntheticScene scene = DistantSphere(&dirs, &intensities);
  WriteDiligentFolder(folder / "sphere", scene, dirs, intensities);
  const PhotometricDataset dataset = LoadPhotometricDataset(folder / "sphere");
  EXPECT_EQ(dataset.kind, PhotometricDataset::Kind::kDistantLights);
  EXPECT_EQ(dataset.num_lights(), 12);
  EXPECT_EQ(dataset.width, 64);
  ASSERT_TRUE(dataset.normal_ground_truth.has_value());
  for (Method method : {Method::kAdaptive, Method::kJacobiSvd}) {
    PhotometricSolverOptions options;
    options.method = method;
    const DatasetSolveResult result = SolveDataset(dataset, options);
    ASSERT_TRUE(result.normal_error_deg.has_value());
    // 16-bit quantisation and the grazing rim: small but not zero.
    EXPECT_LT(result.normal_error_deg->median, 0.05) << PhotometricMethodName(method);
    EXPECT_LT(result.normal_error_deg->mean, 1.0);
    EXPECT_EQ(result.solver.pixels_by_status[int(PixelStatus::kOutsideRegion)],
              dataset.mask.num_pixels() - result.normal_error_deg->num_pixels);
  }
}

TEST(DatasetIoTest, BrokenFilesAreNamedWithLineAndRule) {
  TemporaryFolder folder;
  std::vector<Eigen::Vector3d> dirs, intensities;
  const SyntheticScene scene = DistantSphere(&dirs, &intensities);
  WriteDiligentFolder(folder / "sphere", scene, dirs, intensities);
  std::string text;
  for (int k = 0; k < 12; ++k) text += k == 2 ? "0.1 zero 0.9\n" : "0 0 1\n";
  WriteText(folder / "sphere" / "light_directions.txt", text);
  EXPECT_THAT([&] { LoadPhotometricDataset(folder / "sphere"); },
              ::testing::ThrowsMessage<std::runtime_error>(
                  HasSubstr("light_directions.txt: line 3: 'zero' is not a finite number")));
  WriteText(folder / "sphere" / "light_directions.txt", "0 0 1\n");
  EXPECT_THAT([&] { LoadPhotometricDataset(folder / "sphere"); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("1 lines for 12 images")));
}

// A LUCES-style near-field folder: LEDs around the camera 150-200 mm from a
// plane tilted 15 deg; the lights, K and the plane distance are all the
// solver gets.
TEST(DatasetIoTest, NearFieldFolderSolvesWithPointLights) {
  TemporaryFolder folder;
  const fs::path dir = folder / "plane";
  fs::create_directories(dir);
  const int width = 80, height = 60;
  Eigen::Matrix3d k;
  k << 100, 0, 39.5, 0, 100, 29.5, 0, 0, 1;
  const double distance = 300;
  // Positions in the OpenCV camera frame (y down, z forward), mm.
  std::vector<Eigen::Vector3d> positions_in_cam;
  for (int i = 0; i < 8; ++i) {
    const double angle = 2 * M_PI * i / 8;
    positions_in_cam.emplace_back(150 * std::cos(angle), 150 * std::sin(angle), i % 2 ? 10.0 : -10.0);
  }
  const Eigen::Vector3d flip(1, -1, -1);
  // Ground truth: a plane facing the camera, in the solver frame (z to the camera).
  const Eigen::Vector3d normal = Eigen::Vector3d(0, std::sin(0.26), std::cos(0.26));
  const double mu = 1.5;
  std::string positions, strengths, names;
  std::vector<ImageF> images;
  ImageF truth(width, height, 3);
  for (size_t l = 0; l < positions_in_cam.size(); ++l) {
    const Eigen::Vector3d position = positions_in_cam[l].cwiseProduct(flip);
    const Eigen::Vector3d axis = (Eigen::Vector3d(0, 0, -distance) - position).normalized();
    const Eigen::Vector3d rgb(0.9e5, 1.0e5, 0.8e5 + 1e4 * l);  // reading at 1 mm
    ImageF image(width, height, 3);
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const Eigen::Vector3d ray = k.inverse() * Eigen::Vector3d(x, y, 1);
        const Eigen::Vector3d point = (ray * (distance / ray.z())).cwiseProduct(flip);
        const Eigen::Vector3d to_light = position - point;
        const Eigen::Vector3d l_dir = to_light.normalized();
        const double falloff = std::pow(std::max(0.0, -l_dir.dot(axis)), mu) / to_light.squaredNorm();
        for (int c = 0; c < 3; ++c) image(x, y, c) = float(0.5 * std::max(0.0, normal.dot(l_dir)) * rgb[c] * falloff);
        for (int c = 0; c < 3; ++c) truth(x, y, c) = float(normal[c]);
      }
    }
    char name[32] = {};
    std::snprintf(name, sizeof(name), "%02zu.png", l);
    WritePng(dir / name, ToU16(image), OverwritePolicy::kRefuse);
    names += std::string(name) + "\n";
    positions += std::to_string(positions_in_cam[l].x()) + " " + std::to_string(positions_in_cam[l].y()) + " " +
                 std::to_string(positions_in_cam[l].z()) + "\n";
    strengths += std::to_string(rgb.x()) + " " + std::to_string(rgb.y()) + " " + std::to_string(rgb.z()) + "\n";
  }
  WriteText(dir / "light_positions.txt", positions);
  WriteText(dir / "light_intensities.txt", strengths);
  WriteText(dir / "light_mu.txt", "1.5\n");
  WriteText(dir / "K.txt", "100 0 39.5\n0 100 29.5\n0 0 1\n");
  WriteText(dir / "mean_distance.txt", "300\n");
  WriteMatImage(dir / "Normal_gt.mat", "Normal_gt", truth);

  const PhotometricDataset dataset = LoadPhotometricDataset(dir);
  EXPECT_EQ(dataset.kind, PhotometricDataset::Kind::kNearField);
  EXPECT_DOUBLE_EQ(dataset.surface_distance_mm, 300);
  // The surface is the plane z = const, not the tilted one: the light model is
  // off by the tilt's depth change (a few mm at 300 mm), so a small error remains.
  // No depth refinement: the images are lit at the points of the plane z =
  // 300 mm while their normals are tilted, which no surface has both of, so
  // integrating the normals would move the points off the plane they were lit on.
  DepthRefinementOptions plane_only = DatasetDepthRefinementOptions();
  plane_only.enabled = false;
  const DatasetSolveResult result = SolveDataset(dataset, PhotometricSolverOptions(), plane_only);
  ASSERT_TRUE(result.normal_error_deg.has_value());
  EXPECT_LT(result.normal_error_deg->mean, 1.0);
  EXPECT_EQ(result.unsolved_in_mask, 0u);
  // Distant lights instead (ignoring positions) would be far off.
  EXPECT_GT(dataset.light_positions_mm[0].norm(), 100.0);
  // The view direction points from pixel (0, 0)'s surface point back to the
  // camera at the origin, not +z: its ray K^-1 (0, 0, 1) = (-0.395, -0.295, 1)
  // meets the plane at (-118.5, -88.5, 300) mm (camera frame), which is
  // (-118.5, 88.5, -300) in the solver frame.
  float view[3];
  dataset.MakeLightField()->ViewDirection(0, 0, view);
  const Eigen::Vector3d expected = Eigen::Vector3d(118.5, -88.5, 300).normalized();
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(view[c], expected[c], 1e-5) << c;
}

TEST(DatasetControllerTest, WritesMapsConfidenceAndErrorReport) {
  TemporaryFolder folder;
  std::vector<Eigen::Vector3d> dirs, intensities;
  const SyntheticScene scene = DistantSphere(&dirs, &intensities);
  WriteDiligentFolder(folder / "sphere", scene, dirs, intensities);
  DatasetSolveOptions options;
  options.output_dir = folder / "out";
  DatasetController controller(folder / "sphere", options);
  controller.Run();
  for (const char* name : {"normal.exr", "normal.png", "albedo.exr", "confidence.exr", "status.png",
                           "angular_error_deg.exr", "report.json", "summary.txt"}) {
    EXPECT_TRUE(fs::is_regular_file(folder / "out" / name)) << name;
  }
  std::ifstream in(folder / "out" / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report["solver"]["method"], "adaptive");
  EXPECT_LT(report["ground_truth"]["normal_angular_error_deg"]["median"].get<double>(), 0.05);
  EXPECT_THAT(controller.summary().FullReport(), HasSubstr("mean"));
  // The output folder is never overwritten unless asked.
  DatasetController again(folder / "sphere", options);
  EXPECT_THAT([&] { again.Run(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("already exists")));
}

TEST(DatasetControllerTest, DefaultOutputFolderIsNewBesideEarlierResults) {
  TemporaryFolder folder;
  const auto method = PhotometricSolverOptions::Method::kAdaptive;
  const fs::path first = DefaultDatasetOutputFolder(folder / "out", "data/ballPNG/", method);
  EXPECT_EQ(first, folder / "out" / "ballPNG-adaptive");
  fs::create_directories(first);
  const fs::path second = DefaultDatasetOutputFolder(folder / "out", "data/ballPNG", method);
  EXPECT_EQ(second, folder / "out" / "ballPNG-adaptive-2");
  fs::create_directories(second);
  EXPECT_EQ(DefaultDatasetOutputFolder(folder / "out", "data/ballPNG", method), folder / "out" / "ballPNG-adaptive-3");
  EXPECT_EQ(DefaultDatasetOutputFolder(folder / "out", "data/ballPNG", PhotometricSolverOptions::Method::kQr),
            folder / "out" / "ballPNG-qr");
}

TEST(DatasetControllerTest, RingLightsKeepsASubsetAndSaysWhichFiles) {
  TemporaryFolder folder;
  std::vector<Eigen::Vector3d> dirs, intensities;
  const SyntheticScene scene = DistantSphere(&dirs, &intensities);
  WriteDiligentFolder(folder / "sphere", scene, dirs, intensities);
  DatasetSolveOptions options;
  options.output_dir = folder / "out";
  options.ring_lights = 6;
  DatasetController controller(folder / "sphere", options);
  controller.Run();
  EXPECT_EQ(controller.summary().num_lights, 6);
  EXPECT_EQ(controller.summary().dataset_lights, 12);
  std::ifstream in(folder / "out" / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report["dataset"]["lights"], 6);
  EXPECT_EQ(report["dataset"]["light_subset"]["files"].size(), 6u);
  // Six Lambertian lights still give the sphere exactly.
  EXPECT_LT(report["ground_truth"]["normal_angular_error_deg"]["median"].get<double>(), 0.1);
  options.output_dir = folder / "out2";
  options.ring_lights = 13;
  DatasetController too_many(folder / "sphere", options);
  EXPECT_THAT([&] { too_many.Run(); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("ring_lights = 13")));
}

// Issue #34: the material and its leave-one-light-out check on a Lambertian
// sphere: maps written, no sheen or specular term, both predictions equal.
TEST(DatasetControllerTest, MaterialWritesItsMapsAndTheRelightingCheck) {
  TemporaryFolder folder;
  std::vector<Eigen::Vector3d> dirs, intensities;
  const SyntheticScene scene = DistantSphere(&dirs, &intensities);
  WriteDiligentFolder(folder / "sphere", scene, dirs, intensities);
  DatasetSolveOptions options;
  options.output_dir = folder / "out";
  options.material = true;
  DatasetController controller(folder / "sphere", options);
  controller.Run();
  for (const char* name : {"base_color.exr", "sheen_color.exr", "sheen_roughness.exr", "material_specular.exr",
                           "material_confidence.exr", "material_terms.png"}) {
    EXPECT_TRUE(fs::is_regular_file(folder / "out" / name)) << name;
  }
  std::ifstream in(folder / "out" / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_GT(report["material"]["pixels_fitted"].get<size_t>(), 1000u);
  EXPECT_EQ(report["material"]["pixels_sheen"].get<size_t>(), 0u);
  EXPECT_EQ(report["relighting"]["mode"], "leave_one_light_out");
  EXPECT_EQ(report["relighting"]["lights"].size(), 12u);
  EXPECT_EQ(report["relighting"]["lights"][0]["file"], "001.png");
  // The sphere is Lambertian: the material is albedo x n.l, whose prediction
  // is off by the 16-bit rounding and the sphere's rim alone.
  EXPECT_NEAR(report["relighting"]["ratio"].get<double>(), 1.0, 1e-6);
  EXPECT_LT(report["relighting"]["lambertian_error"].get<double>(), 0.01);
  EXPECT_THAT(controller.summary().FullReport(), HasSubstr("(leave_one_light_out)"));
}

// --fit-lights and --predict-dir: the photos of the other lights predicted,
// in the photos' format and bit depth, close to them.
TEST(DatasetControllerTest, FitLightsPredictsTheOtherLightsAsPhotos) {
  TemporaryFolder folder;
  std::vector<Eigen::Vector3d> dirs, intensities;
  const SyntheticScene scene = DistantSphere(&dirs, &intensities);
  WriteDiligentFolder(folder / "sphere", scene, dirs, intensities);
  DatasetSolveOptions options;
  options.output_dir = folder / "out";
  options.fit_lights = {1, 2, 3, 5, 7, 9, 11, 12};
  options.predict_dir = folder / "predicted";
  DatasetController controller(folder / "sphere", options);
  controller.Run();
  EXPECT_EQ(controller.summary().num_lights, 8);
  EXPECT_EQ(controller.summary().predicted_files, (std::vector<std::string>{"004.png", "006.png", "008.png", "010.png"}));
  for (const char* name : {"004.png", "006.png", "008.png", "010.png"}) {
    const fs::path predicted = folder / "predicted" / name;
    ASSERT_TRUE(fs::is_regular_file(predicted)) << name;
    EXPECT_EQ(ReadImageFileInfo(predicted).bits_per_sample, 16);
    // On the pixels that have a material (the sphere; the scene's background is not fitted).
    const ImageF photo = ReadImageFloat(folder / "sphere" / name), guess = ReadImageFloat(predicted);
    const ImageU8 terms = ReadImageU8(folder / "out" / "material_terms.png");
    double error = 0, sum = 0;
    for (size_t i = 0; i < photo.size(); ++i) {
      if ((terms.data()[i / 3] & kMaterialFitted) == 0) continue;
      error += std::abs(photo.data()[i] - guess.data()[i]), sum += photo.data()[i];
    }
    EXPECT_GT(sum, 0);
    EXPECT_LT(error / sum, 0.001) << name;
  }
  EXPECT_FALSE(fs::exists(folder / "predicted" / "001.png"));  // a fitted light is not predicted
  std::ifstream in(folder / "out" / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report["relighting"]["mode"], "fit_lights");
  EXPECT_EQ(report["relighting"]["lights"].size(), 4u);
  // Bad light numbers name the option's field and the rule.
  options.output_dir = folder / "out2";
  options.predict_dir.clear();
  options.fit_lights = {1, 2, 3, 4, 5, 13};
  DatasetController out_of_range(folder / "sphere", options);
  EXPECT_THAT([&] { out_of_range.Run(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("fit_lights = 13")));
  options.fit_lights = {1, 2, 3};
  EXPECT_THAT([&] { options.Check(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("at least 6")));
  options.fit_lights = {};
  options.predict_dir = folder / "predicted2";
  EXPECT_THAT([&] { options.Check(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("needs fit_lights")));
}

// The DiLiGenT benchmark itself (ball and bear), when the data are there.
fs::path DiligentFolder() { return fs::path(SCANBENCH_SOURCE_DIR) / ".." / "shared" / "data" / "diligent"; }

class DiligentTest : public ::testing::TestWithParam<std::tuple<const char*, double>> {};

TEST_P(DiligentTest, LeastSquaresReproducesThePublishedBaselineAndTheDefaultIsWellBelow) {
  const fs::path folder = DiligentFolder() / (std::string(std::get<0>(GetParam())) + "PNG");
  if (!fs::is_directory(folder)) {
    GTEST_SKIP() << "DiLiGenT data not found at " << folder.string()
                 << " (../shared/data/diligent beside the repository); skipping the reproduction";
  }
  const PhotometricDataset dataset = LoadPhotometricDataset(folder);
  ASSERT_EQ(dataset.num_lights(), 96);
  // The benchmark's baseline: every sample, pseudo-inverse, normalise.
  PhotometricSolverOptions lsq;
  lsq.method = Method::kJacobiSvd;
  lsq.min_sample_value = 0;
  const DatasetSolveResult baseline = SolveDataset(dataset, lsq);
  ASSERT_TRUE(baseline.normal_error_deg.has_value());
  const double published = std::get<1>(GetParam());
  EXPECT_NEAR(baseline.normal_error_deg->mean, published, 0.15);
  // The robust default: well below least squares (measured ball 1.92, bear 6.21).
  const DatasetSolveResult robust = SolveDataset(dataset, PhotometricSolverOptions());
  EXPECT_LT(robust.normal_error_deg->mean, published - 1.5) << robust.solver.BriefReport();
  EXPECT_EQ(robust.unsolved_in_mask, 0u);
}

INSTANTIATE_TEST_SUITE_P(BallAndBear, DiligentTest,
                         ::testing::Values(std::make_tuple("ball", 4.10), std::make_tuple("bear", 8.39)),
                         [](const auto& param_info) { return std::string(std::get<0>(param_info.param)); });

}  // namespace
}  // namespace scanbench

namespace scanbench {
namespace {

TEST(SolverReportTest, TableAndPlotHoldEveryRow) {
  std::vector<SolverReportRow> rows;
  for (const char* scene : {"scene a", "scene b"}) {
    for (const char* method : {"adaptive", "jacobi_svd", "robust_irls"}) {
      SolverReportRow row;
      row.scene = scene;
      row.method = method;
      row.mean_error_deg = std::string(method) == "adaptive" ? 0.5 : 1.0;
      row.megapixels_per_second = std::string(method) == "jacobi_svd" ? 0.5 : 3.0;
      row.threads = 2;
      rows.push_back(row);
    }
  }
  SolverReportSummary summary;
  summary.rows = rows;
  summary.skipped.push_back("the 16 MP scene");
  const std::string table = summary.MarkdownTable();
  EXPECT_THAT(table, HasSubstr("| scene a | adaptive | 0.50 |"));
  EXPECT_THAT(table, HasSubstr("Left out: the 16 MP scene"));
  const std::string svg = ErrorVsTimeSvg(rows);
  EXPECT_THAT(svg, HasSubstr("<svg"));
  EXPECT_THAT(svg, HasSubstr("scene b"));
  size_t circles = 0;
  for (size_t at = svg.find("<circle"); at != std::string::npos; at = svg.find("<circle", at + 1)) ++circles;
  EXPECT_EQ(circles, 3u + rows.size());  // legend + one point per row
  EXPECT_THAT(svg, HasSubstr("<path d=\"M"));  // the Pareto front
}

// The scene list, planned without building or solving anything (the full
// report takes minutes): cloth and satin through the RAW path, and DiLiGenT
// at 96 and at 10 ring lights when the folders exist.
TEST(SolverReportTest, ScenesIncludeClothSatinAndRingSubsets) {
  TemporaryFolder folder;
  SolverReportOptions options;
  options.output_dir = folder.path() / "out";
  options.include_16mp = false;
  options.diligent_dir = folder.path() / "diligent";
  options.diligent_crop8_dir = folder.path() / "diligent_crop8";
  std::vector<std::string> skipped;
  const std::vector<std::string> without = SolverReportSceneNames(options, &skipped);
  EXPECT_EQ(without.size(), 7u);  // 3 analytic, 4 rig
  EXPECT_EQ(skipped.size(), 11u);  // 16 MP, ball, bear, buddha, goblet, pot1 at 96 and at 10 lights
  EXPECT_THAT(without[5], HasSubstr("rig cloth twill 1232x816, RAW"));
  EXPECT_THAT(without[6], HasSubstr("rig satin 1232x816, RAW"));
  EXPECT_THAT(skipped.back(), HasSubstr("pot1PNG with 10 ring lights"));

  fs::create_directories(options.diligent_dir / "ballPNG");
  fs::create_directories(options.diligent_dir / "bearPNG");
  const std::vector<std::string> with = SolverReportSceneNames(options);
  ASSERT_EQ(with.size(), 11u);
  EXPECT_EQ(with[7], "DiLiGenT ballPNG (96 lights)");
  EXPECT_EQ(with[8], "DiLiGenT bearPNG (96 lights)");
  EXPECT_EQ(with[9], "DiLiGenT ballPNG (10 ring lights)");
  EXPECT_EQ(with[10], "DiLiGenT bearPNG (10 ring lights)");
}

TEST(SolverReportTest, OptionsAreChecked) {
  SolverReportOptions options;
  EXPECT_THAT([&] { options.Check(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("output_dir")));
  options.output_dir = "x";
  options.analytic_size = 10;
  EXPECT_THAT([&] { options.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("analytic_size = 10 must lie in [64, 4096]")));
}

}  // namespace
}  // namespace scanbench
