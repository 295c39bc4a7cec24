// The learned method and the default's use of the network (solver/learned_kernel.h)
// on analytic scenes with ground truth.
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "solver/angular_error.h"
#include "solver/photometric_methods.h"
#include "solver/photometric_solver.h"
#include "solver/synthetic_scene.h"
#include "tests/solver/solver_test_util.h"

namespace scanbench {
namespace {

using Method = PhotometricSolverOptions::Method;
using testing::CountStatus;
using testing::ExpectAllFinite;
using testing::InputFor;

ImageU8 ObjectPixels(const SyntheticScene& scene) { return scene.object; }

PhotometricSolverSummary Solve(const SyntheticScene& scene, PhotometricSolverOptions options,
                               PhotometricSolution* solution) {
  options.num_threads = 2;
  return SolvePhotometricStereo(options, InputFor(scene), solution);
}

double MeanError(const SyntheticScene& scene, const PhotometricSolution& solution) {
  return AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, ObjectPixels(scene)).mean;
}

// Median of the network's expected error over the solved object pixels.
double MedianExpectedError(const SyntheticScene& scene, const PhotometricSolution& solution) {
  std::vector<float> values;
  const ImageU8 object = ObjectPixels(scene);
  for (int y = 0; y < scene.normal_in_table.height(); ++y) {
    for (int x = 0; x < scene.normal_in_table.width(); ++x) {
      if (object(x, y) && solution.status(x, y) == static_cast<uint8_t>(PixelStatus::kSolved)) {
        values.push_back(solution.learned_error_deg(x, y));
      }
    }
  }
  if (values.empty()) return 0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// A shiny sphere at the rig's 10 lights: least squares is pulled towards the
// highlights, the network is not, and every output is finite.
TEST(LearnedTest, ShinySphereBeatsLeastSquaresAndWritesItsExpectedError) {
  SyntheticSceneOptions o;
  o.specular = 0.6;
  o.shininess = 60;
  o.num_lights = 10;
  o.noise_stddev = 0.002;
  const SyntheticScene scene = MakeSyntheticScene(o);
  PhotometricSolverOptions lsq;
  lsq.method = Method::kJacobiSvd;
  PhotometricSolution lsq_solution, learned_solution;
  Solve(scene, lsq, &lsq_solution);
  PhotometricSolverOptions learned;
  learned.method = Method::kLearned;
  const PhotometricSolverSummary summary = Solve(scene, learned, &learned_solution);
  ExpectAllFinite(learned_solution);
  EXPECT_LT(MeanError(scene, learned_solution), 0.8 * MeanError(scene, lsq_solution)) << summary.BriefReport();
  EXPECT_EQ(summary.learned_model, "data/models/normal_net.bin");
  EXPECT_EQ(summary.learned_model_sha256.size(), 64u);
  EXPECT_NE(summary.BriefReport().find("network data/models/normal_net.bin"), std::string::npos);
  ASSERT_FALSE(learned_solution.learned_error_deg.empty());
  const double expected = MedianExpectedError(scene, learned_solution);
  EXPECT_GT(expected, 0.1);
  EXPECT_LT(expected, 20.0);
}

// Lights bunched near the view axis: the normal's tilt is barely observed, and
// the network says so: its expected error is well above that of a well-spread set.
TEST(LearnedTest, ExpectedErrorRisesWhereTheLightsSayLittle) {
  SyntheticSceneOptions spread;
  spread.num_lights = 10;
  spread.noise_stddev = 0.003;
  SyntheticSceneOptions bunched = spread;
  bunched.min_elevation_deg = 82;
  bunched.max_elevation_deg = 86;
  PhotometricSolverOptions learned;
  learned.method = Method::kLearned;
  learned.max_condition_number = 1e6;  // let the bunched set through: the test is the network's confidence
  PhotometricSolution a, b;
  const SyntheticScene spread_scene = MakeSyntheticScene(spread), bunched_scene = MakeSyntheticScene(bunched);
  Solve(spread_scene, learned, &a);
  Solve(bunched_scene, learned, &b);
  ExpectAllFinite(b);
  EXPECT_GT(MedianExpectedError(bunched_scene, b), 2.0 * MedianExpectedError(spread_scene, a));
}

// Too few valid samples: flagged, the placeholder normal, never NaN.
TEST(LearnedTest, TooFewSamplesAreFlagged) {
  SyntheticSceneOptions o;
  o.num_lights = 3;
  o.shape = SyntheticSceneOptions::Shape::kTiltedPlane;
  const SyntheticScene scene = MakeSyntheticScene(o);
  PhotometricSolverInput input = InputFor(scene);
  ImageU8 invalid(scene.images[0].width(), scene.images[0].height(), 1, uint8_t{0});
  ImageU8 valid(scene.images[0].width(), scene.images[0].height(), 1, uint8_t{1});
  input.sample_valid = {&invalid, &valid, &valid};  // two samples left per pixel
  PhotometricSolverOptions learned;
  learned.method = Method::kLearned;
  PhotometricSolution solution;
  SolvePhotometricStereo(learned, input, &solution);
  ExpectAllFinite(solution);
  EXPECT_EQ(CountStatus(solution, PixelStatus::kTooFewLights), solution.status.num_pixels());
  EXPECT_EQ(solution.normal_in_table(5, 5, 2), 1.0f);
}

// --learned unsupported takes the network only where the lobe fit keeps no
// lobe, with at most adaptive_learned_max_lights lights and at least 6 tokens;
// the default (never) runs no network at all. On a Lambertian sphere only the
// few robust pixels change, within a tenth of a degree on the mean (measured
// 0.17 -> 0.27: the network's floor on the noisy pixels the robust pass gets;
// one reason it is not the default).
TEST(LearnedTest, AdaptiveUseKeepsLambertianScenesAndRespectsItsLimits) {
  PhotometricSolverOptions unsupported;
  unsupported.adaptive_learned = PhotometricSolverOptions::LearnedUse::kUnsupportedLobe;
  EXPECT_FALSE(MethodRunsPass(PhotometricSolverOptions(), SolverPass::kLearnedNormals)) << "off by default";
  EXPECT_TRUE(MethodRunsPass(unsupported, SolverPass::kLearnedNormals));
  SyntheticSceneOptions o;
  o.num_lights = 10;
  o.noise_stddev = 0.002;
  const SyntheticScene scene = MakeSyntheticScene(o);
  PhotometricSolution with, without;
  const PhotometricSolverSummary lambertian = Solve(scene, unsupported, &with);
  Solve(scene, PhotometricSolverOptions(), &without);
  EXPECT_LT(MeanError(scene, with), MeanError(scene, without) + 0.15);
  EXPECT_LT(lambertian.pixels_by_path[int(SolvePath::kLearned)], lambertian.num_solved() / 5);
  // A shiny sphere has robust pixels without a lobe at 10 lights: some take the
  // network; with the limit below the light count, none do.
  SyntheticSceneOptions shiny = o;
  shiny.specular = 0.6;
  shiny.shininess = 60;
  const SyntheticScene shiny_scene = MakeSyntheticScene(shiny);
  PhotometricSolution s1, s2;
  const PhotometricSolverSummary on = Solve(shiny_scene, unsupported, &s1);
  PhotometricSolverOptions limited = unsupported;
  limited.adaptive_learned_max_lights = 9;
  const PhotometricSolverSummary off = Solve(shiny_scene, limited, &s2);
  EXPECT_GT(on.pixels_by_path[int(SolvePath::kLearned)], 0u) << on.BriefReport();
  EXPECT_FALSE(on.learned_model.empty());
  EXPECT_EQ(off.pixels_by_path[int(SolvePath::kLearned)], 0u) << off.BriefReport();
  EXPECT_TRUE(off.learned_model.empty());
  ExpectAllFinite(s1);
  // Five lights: below the fewest the network was trained on, the robust fit stays.
  SyntheticSceneOptions few = shiny;
  few.num_lights = 5;
  const SyntheticScene few_scene = MakeSyntheticScene(few);
  PhotometricSolution s3;
  EXPECT_EQ(Solve(few_scene, unsupported, &s3).pixels_by_path[int(SolvePath::kLearned)], 0u);
}

}  // namespace
}  // namespace scanbench
