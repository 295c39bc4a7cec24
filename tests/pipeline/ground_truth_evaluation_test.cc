// The solve's evaluation against a ground truth, band by band
// (GroundTruthEvaluation), on a synthetic truth held in memory: every figure
// equals the whole-frame computation's (the angles' and the albedo errors'
// median and p95 those of the values rounded to float), with uniform regions
// (a chart's patches) and a textile's per-pixel colours, and bands that do
// not divide the height.
#include "pipeline/ground_truth_evaluation.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "pipeline/banded_solve.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;

constexpr int kWidth = 101, kHeight = 67;

// The truth held whole, handed out a band of rows at a time.
class HeldTruth final : public GroundTruthRows {
 public:
  HeldTruth(ImageF normals, ImageF albedo) : normals_(std::move(normals)), albedo_(std::move(albedo)) {}
  void ReadNormalRows(int y_begin, int y_end, ImageF* rows) override { Copy(normals_, y_begin, y_end, rows); }
  void ReadAlbedoRows(int y_begin, int y_end, ImageF* rows) override { Copy(albedo_, y_begin, y_end, rows); }

 private:
  static void Copy(const ImageF& whole, int y_begin, int y_end, ImageF* rows) {
    *rows = ImageF(whole.width(), y_end - y_begin, whole.channels());
    std::copy(whole.row(y_begin), whole.row(y_end - 1) + size_t(whole.width()) * whole.channels(), rows->data());
  }
  ImageF normals_, albedo_;
};

struct Scene {
  ImageF truth_normals, truth_albedo;
  ImageU8 on_sample;
  PhotometricSolution solution;  // the truth a little off, some pixels unsolved
};

// Unit normals tilted at random; an albedo of four uniform patches (regions
// of the colour comparison) on the left, a colour per pixel on the right; the
// sample an ellipse; the solution off by noise, every 97th pixel unsolved.
Scene MakeScene() {
  Scene scene;
  scene.truth_normals = ImageF(kWidth, kHeight, 3);
  scene.truth_albedo = ImageF(kWidth, kHeight, 3);
  scene.on_sample = ImageU8(kWidth, kHeight, 1);
  std::mt19937 random(11);
  std::uniform_real_distribution<float> tilt(-0.3f, 0.3f), colour(0.05f, 0.9f);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const float nx = tilt(random), ny = tilt(random), norm = std::sqrt(nx * nx + ny * ny + 1);
      scene.truth_normals(x, y, 0) = nx / norm;
      scene.truth_normals(x, y, 1) = ny / norm;
      scene.truth_normals(x, y, 2) = 1 / norm;
      const int patch = x < kWidth / 2 ? (x / 25) + 2 * (y / 34) : -1;
      for (int c = 0; c < 3; ++c) {
        scene.truth_albedo(x, y, c) = patch >= 0 ? 0.1f + 0.2f * patch + 0.05f * c : colour(random);
      }
      const double ex = (x - kWidth / 2.0) / (0.48 * kWidth), ey = (y - kHeight / 2.0) / (0.48 * kHeight);
      scene.on_sample(x, y, 0) = ex * ex + ey * ey <= 1;
    }
  }
  PhotometricSolution& solution = scene.solution;
  solution.normal_in_table = scene.truth_normals;
  solution.albedo = scene.truth_albedo;
  solution.status = ImageU8(kWidth, kHeight, 1, static_cast<uint8_t>(PixelStatus::kSolved));
  std::normal_distribution<float> noise(0.0f, 0.02f);
  for (size_t i = 0; i < solution.status.num_pixels(); ++i) {
    for (int c = 0; c < 3; ++c) {
      solution.normal_in_table.data()[3 * i + c] += noise(random);
      solution.albedo.data()[3 * i + c] *= 1.0f + noise(random);
    }
    if (i % 97 == 0) solution.status.data()[i] = static_cast<uint8_t>(PixelStatus::kNoSignal);
  }
  return scene;
}

std::unique_ptr<GroundTruthRows> TruthOf(const Scene& scene) {
  return std::make_unique<HeldTruth>(scene.truth_normals, scene.truth_albedo);
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

TEST(GroundTruthEvaluationTest, BandedFiguresEqualTheWholeFrameOnes) {
  const Scene scene = MakeScene();
  ImageU8 evaluated(kWidth, kHeight, 1);
  size_t unsolved = 0;
  for (size_t i = 0; i < evaluated.num_pixels(); ++i) {
    const bool on_sample = scene.on_sample.data()[i] != 0;
    const bool solved = scene.solution.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved);
    evaluated.data()[i] = on_sample && solved;
    unsolved += on_sample && !solved;
  }
  const PhotometricSolution& solution = scene.solution;
  const AlbedoColorErrors whole_color = CompareAlbedoColor(solution.albedo, scene.truth_albedo, evaluated);
  EXPECT_EQ(whole_color.regions.size(), 4u) << "the patches must be regions";
  const ImageF whole_map = AngularErrorMapDegrees(solution.normal_in_table, scene.truth_normals, evaluated);
  for (const int band_rows : {7, kEvaluationBandRows}) {
    SCOPED_TRACE(band_rows);
    const GroundTruthComparison banded = CompareWithGroundTruth(scene.on_sample, TruthOf(scene), solution, 2, band_rows);
    ExpectSameStatistics(banded.normal_error_deg,
                         AngularErrorDegrees(solution.normal_in_table, scene.truth_normals, evaluated), "normals",
                         /*rounded_quantiles=*/true);
    ExpectSameStatistics(banded.albedo_error, AbsoluteError(solution.albedo, scene.truth_albedo, evaluated), "albedo",
                         /*rounded_quantiles=*/true);
    ExpectSameStatistics(banded.albedo_color_error.delta_e, whole_color.delta_e, "CIEDE2000");
    EXPECT_EQ(banded.albedo_color_error.ReportJson(), whole_color.ReportJson());
    EXPECT_EQ(banded.unsolved_on_sample, unsolved);
    ASSERT_TRUE(banded.angular_error_deg.SameSize(whole_map));
    EXPECT_TRUE(std::equal(whole_map.data(), whole_map.data() + whole_map.size(), banded.angular_error_deg.data()));
  }
}

TEST(GroundTruthEvaluationTest, MisfitBandsAndTruthRowsAreRefused) {
  const Scene scene = MakeScene();
  GroundTruthEvaluation evaluation(scene.on_sample, TruthOf(scene));
  EXPECT_EQ(evaluation.AddBand(SolutionRows(scene.solution, 0, 10), 1).height(), 10);
  EXPECT_THAT([&] { evaluation.Finish(); },
              ::testing::ThrowsMessage<std::logic_error>(HasSubstr("10 of 67 rows added")));
  PhotometricSolution narrow;
  narrow.normal_in_table = ImageF(kWidth - 1, 5, 3);
  narrow.albedo = ImageF(kWidth - 1, 5, 3);
  narrow.status = ImageU8(kWidth - 1, 5, 1);
  EXPECT_THAT([&] { evaluation.AddBand(narrow); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("a band of 100x5x1")));
  // A truth whose rows are not the sample mask's width.
  const auto narrow_albedo = [] { return std::make_unique<HeldTruth>(ImageF(kWidth, kHeight, 3), ImageF(kWidth - 1, kHeight, 3)); };
  EXPECT_THAT([&] { GroundTruthEvaluation(scene.on_sample, narrow_albedo()); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("the truth's albedo rows are 100x67x3")));
  EXPECT_THROW(GroundTruthEvaluation(ImageU8(), TruthOf(scene)), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
