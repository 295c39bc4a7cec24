// The shared velvet sheen (solver/coherent_sheen.h) on synthetic scenes with
// ground truth (fixed seeds): a velvet sphere whose sheen it recovers and
// removes from the normals (RGB and Bayer domain), a Lambertian scene it must
// leave bit for bit, a diffuse-coloured residual the dichromatic test turns
// down, and the stiff inputs (near field, unsolved pixels, threads, cancel,
// bad options).
#include "solver/coherent_sheen.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "solver/angular_error.h"
#include "solver/photometric_solver.h"
#include "solver/pixel_solvers.h"
#include "solver/synthetic_scene.h"
#include "tests/solver/solver_test_util.h"

namespace scanbench {
namespace {

using testing::ExpectAllFinite;
using testing::InputFor;
using testing::NormalAt;

constexpr double kSheenF0 = 0.05;
constexpr double kSheenWidth = 0.9;

// Adds a white velvet sheen (the seed's cloth BRDF's sheen, F0 x
// VelvetSheenShape, viewer along +z) times each light's intensity to every
// channel; with `coloured`, the same added term is scaled by the pixel's
// albedo instead (not a sheen: an error of the diffuse model).
void AddSheen(double f0, double width, bool coloured, SyntheticScene* scene) {
  const int width_px = scene->normal_in_table.width(), height = scene->normal_in_table.height();
  const int lights = scene->light_field->num_lights();
  std::vector<float> dirs(3 * lights), intensities(3 * lights);
  const Eigen::Vector3d view = Eigen::Vector3d::UnitZ();
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width_px; ++x) {
      scene->light_field->Evaluate(x, y, dirs.data(), intensities.data());
      const Eigen::Vector3d n = NormalAt(scene->normal_in_table, x, y);
      for (int k = 0; k < lights; ++k) {
        const Eigen::Vector3d l(dirs[3 * k], dirs[3 * k + 1], dirs[3 * k + 2]);
        const double sheen = f0 * VelvetSheenShape(n, l, (l + view).normalized(), view, width);
        for (int c = 0; c < 3; ++c) {
          const double scale = coloured ? scene->albedo(x, y, c) / 0.3 : 1.0;
          scene->images[k](x, y, c) += float(scale * sheen * intensities[3 * k + c]);
        }
      }
    }
  }
}

SyntheticSceneOptions SphereOptions() {
  SyntheticSceneOptions options;
  options.width = options.height = 128;
  options.num_lights = 10;
  options.albedo = {0.08, 0.10, 0.30};  // dark blue: the sheen is a large part of the reading
  options.noise_stddev = 0.0003;
  options.seed = 11;
  return options;
}

struct SolveRun {
  PhotometricSolution solution;
  PhotometricSolverSummary summary;
  double mean_error = 0;
};

SolveRun Solve(const SyntheticScene& scene, bool coherent_sheen, int threads = 2) {
  PhotometricSolverOptions options;
  options.adaptive_coherent_sheen = coherent_sheen;
  options.num_threads = threads;
  SolveRun run;
  run.summary = SolvePhotometricStereo(options, InputFor(scene), &run.solution);
  run.mean_error = AngularErrorDegrees(run.solution.normal_in_table, scene.normal_in_table, scene.object).mean;
  return run;
}

template <typename T>
bool SameBits(const Image<T>& a, const Image<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

bool SameSolution(const PhotometricSolution& a, const PhotometricSolution& b) {
  return SameBits(a.normal_in_table, b.normal_in_table) && SameBits(a.albedo, b.albedo) &&
         SameBits(a.residual, b.residual) && SameBits(a.status, b.status) && SameBits(a.solve_path, b.solve_path);
}

TEST(CoherentSheen, SplitShapeIsVelvetSheenShape) {
  const Eigen::Vector3d v = Eigen::Vector3d(0.1, 0.2, 1).normalized();
  for (const Eigen::Vector3d& n : {Eigen::Vector3d(0.2, -0.1, 1).normalized(), Eigen::Vector3d::UnitZ().eval()}) {
    for (const Eigen::Vector3d& l : {Eigen::Vector3d(0.6, 0.3, 0.7).normalized(), Eigen::Vector3d(-0.9, 0, 0.3).normalized(),
                                     Eigen::Vector3d(0, 0, -1).eval()}) {
      const Eigen::Vector3d h = (l + v).normalized();
      for (double a : {0.3, 0.9, 2.0}) {
        EXPECT_NEAR(VelvetSheenOf(VelvetSheenGeometryOf(n, l, h, v), a), VelvetSheenShape(n, l, h, v, a), 1e-15);
      }
    }
  }
}

// The sheen sphere: the shared sheen is found with about its F0 and width,
// and the normals lose most of the bias the sheen put into least squares.
TEST(CoherentSheen, RecoversTheSheenAndImprovesTheNormals) {
  SyntheticScene velvet = MakeSyntheticScene(SphereOptions());
  AddSheen(kSheenF0, kSheenWidth, false, &velvet);
  const SolveRun off = Solve(velvet, false);
  ASSERT_GT(off.mean_error, 0.5) << "the sheen must bias least squares for the test to mean anything";
  const SolveRun on = Solve(velvet, true);
  ExpectAllFinite(on.solution);
  EXPECT_LT(on.mean_error, 0.4 * off.mean_error);
  EXPECT_GT(on.summary.pixels_coherent_sheen, velvet.object.num_pixels() / 3);

  // The pass alone on the least-squares result, for its fitted figures.
  PhotometricSolverOptions options;
  options.adaptive_coherent_sheen = false;
  PhotometricSolution solution;
  SolvePhotometricStereo(options, InputFor(velvet), &solution);
  const CoherentSheenSummary summary = RefineCoherentSheen(CoherentSheenOptions(), options, InputFor(velvet), &solution);
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  EXPECT_GT(summary.groups_taken, 0.5 * summary.groups_tried) << summary.BriefReport();
  EXPECT_NEAR(summary.mean_f0, kSheenF0, 0.2 * kSheenF0) << summary.BriefReport();
  EXPECT_NEAR(summary.mean_width, kSheenWidth, 0.2) << summary.BriefReport();
  EXPECT_EQ(summary.pixels_refined, on.summary.pixels_coherent_sheen);
  EXPECT_TRUE(SameBits(solution.normal_in_table, on.solution.normal_in_table));
  // The white sheen is out of the albedo too.
  const double albedo_off = std::abs(off.solution.albedo(64, 64, 2) - 0.30);
  const double albedo_on = std::abs(on.solution.albedo(64, 64, 2) - 0.30);
  EXPECT_LT(albedo_on, albedo_off);
}

// A Lambertian scene (noise, same lights): no group takes the sheen, and the
// solution is least squares' bit for bit.
TEST(CoherentSheen, LeavesALambertianSceneBitForBit) {
  for (auto lights : {SyntheticSceneOptions::Lights::kDistant, SyntheticSceneOptions::Lights::kNearField}) {
    SyntheticSceneOptions scene_options = SphereOptions();
    scene_options.lights = lights;
    const SyntheticScene lambert = MakeSyntheticScene(scene_options);
    const SolveRun off = Solve(lambert, false);
    const SolveRun on = Solve(lambert, true);
    EXPECT_EQ(on.summary.pixels_coherent_sheen, 0u);
    EXPECT_TRUE(SameSolution(off.solution, on.solution));
  }
}

// The gate (gate_ratio): on the Lambertian sphere it turns every block down
// after its one look, and gate_ratio 0 (every block fitted) shows it saves
// fits only: the result is the same, nothing taken. On the velvet sphere
// every block it looks at goes on to the fit, and the groups take the sheen.
TEST(CoherentSheen, GateSkipsLambertianBlocksAndKeepsVelvetOnes) {
  PhotometricSolverOptions options;
  options.adaptive_coherent_sheen = false;
  const SyntheticScene lambert = MakeSyntheticScene(SphereOptions());
  PhotometricSolution least_squares;
  SolvePhotometricStereo(options, InputFor(lambert), &least_squares);
  PhotometricSolution gated = least_squares, ungated = least_squares;
  const CoherentSheenSummary skipped = RefineCoherentSheen(CoherentSheenOptions(), options, InputFor(lambert), &gated);
  ASSERT_TRUE(skipped.IsUsable()) << skipped.message;
  EXPECT_GE(skipped.blocks_gated, 12u) << skipped.BriefReport();  // 16 blocks of 32 px, most with candidates
  EXPECT_EQ(skipped.blocks_passed, 0u) << skipped.BriefReport();
  EXPECT_EQ(skipped.groups_tried, 0u);
  CoherentSheenOptions no_gate;
  no_gate.gate_ratio = 0;
  const CoherentSheenSummary fitted = RefineCoherentSheen(no_gate, options, InputFor(lambert), &ungated);
  EXPECT_EQ(fitted.blocks_passed, fitted.blocks_gated);
  EXPECT_GE(fitted.groups_tried, fitted.blocks_passed);
  EXPECT_EQ(fitted.groups_taken, 0u) << fitted.BriefReport();
  EXPECT_TRUE(SameSolution(gated, least_squares));
  EXPECT_TRUE(SameSolution(ungated, least_squares));

  SyntheticScene velvet = MakeSyntheticScene(SphereOptions());
  AddSheen(kSheenF0, kSheenWidth, false, &velvet);
  PhotometricSolution solution;
  SolvePhotometricStereo(options, InputFor(velvet), &solution);
  const CoherentSheenSummary kept = RefineCoherentSheen(CoherentSheenOptions(), options, InputFor(velvet), &solution);
  EXPECT_GE(kept.blocks_gated, 12u) << kept.BriefReport();
  EXPECT_EQ(kept.blocks_passed, kept.blocks_gated) << kept.BriefReport();
  EXPECT_GT(kept.groups_taken, kept.blocks_passed / 2) << kept.BriefReport();
}

// A residual in the albedo's colour (an error of the diffuse model, not a
// white sheen) of the same shape: the dichromatic test turns it down, and
// without that test the pass would have taken it.
TEST(CoherentSheen, DichromaticTestRejectsAnAlbedoColouredResidual) {
  SyntheticScene coloured = MakeSyntheticScene(SphereOptions());
  AddSheen(kSheenF0, kSheenWidth, true, &coloured);
  PhotometricSolverOptions options;
  options.adaptive_coherent_sheen = false;
  PhotometricSolution least_squares;
  SolvePhotometricStereo(options, InputFor(coloured), &least_squares);
  PhotometricSolution solution = least_squares;
  const CoherentSheenSummary with_test =
      RefineCoherentSheen(CoherentSheenOptions(), options, InputFor(coloured), &solution);
  EXPECT_EQ(with_test.groups_taken, 0u) << with_test.BriefReport();
  EXPECT_TRUE(SameSolution(solution, least_squares));
  CoherentSheenOptions no_test;
  no_test.dichromatic = false;
  const CoherentSheenSummary without_test = RefineCoherentSheen(no_test, options, InputFor(coloured), &solution);
  EXPECT_GT(without_test.groups_taken, 0u) << without_test.BriefReport();
}

// The Bayer domain (one CFA channel per raw pixel): the pass runs there too
// and removes most of the sheen's bias.
TEST(CoherentSheen, RunsInTheBayerDomain) {
  // Lighter threads than the RGB test's: on a dark red raw pixel the sheen
  // is most of the reading and its residual sends the pixel to the robust
  // pass, which the shared sheen leaves alone.
  SyntheticSceneOptions options = SphereOptions();
  options.albedo = {0.25, 0.30, 0.45};
  SyntheticScene velvet = MakeSyntheticScene(options);
  AddSheen(kSheenF0, kSheenWidth, false, &velvet);
  const std::array<int, 4> rggb = {0, 1, 1, 2};
  std::vector<ImageF> mosaics;
  for (const ImageF& image : velvet.images) {
    ImageF mosaic(image.width(), image.height(), 1);
    for (int y = 0; y < image.height(); ++y) {
      for (int x = 0; x < image.width(); ++x) mosaic(x, y) = image(x, y, rggb[(y & 1) * 2 + (x & 1)]);
    }
    mosaics.push_back(std::move(mosaic));
  }
  BayerSolverInput input;
  for (const ImageF& mosaic : mosaics) input.mosaics.push_back(&mosaic);
  input.cfa_channels = rggb;
  input.light_field = velvet.light_field.get();
  double error[2];
  for (int on = 0; on < 2; ++on) {
    PhotometricSolverOptions solver_options;
    solver_options.adaptive_coherent_sheen = on == 1;
    PhotometricSolution solution;
    const PhotometricSolverSummary summary = SolvePhotometricStereoBayer(solver_options, input, &solution);
    ASSERT_TRUE(summary.IsUsable()) << summary.message;
    ExpectAllFinite(solution);
    error[on] = AngularErrorDegrees(solution.normal_in_table, velvet.normal_in_table, velvet.object).mean;
    if (on == 1) {
      EXPECT_GT(summary.pixels_coherent_sheen, 0u);
    }
  }
  ASSERT_GT(error[0], 0.5);
  EXPECT_LT(error[1], 0.5 * error[0]);
}

// Near-field LEDs, a region that leaves pixels out, and more lights than the
// pass takes: no NaN, unsolved and outside pixels untouched and flagged,
// the same result on any thread count.
TEST(CoherentSheen, StiffInputs) {
  SyntheticSceneOptions scene_options = SphereOptions();
  scene_options.lights = SyntheticSceneOptions::Lights::kNearField;
  SyntheticScene velvet = MakeSyntheticScene(scene_options);
  AddSheen(kSheenF0, kSheenWidth, false, &velvet);
  ImageU8 region(128, 128, 1, uint8_t{1});
  for (int y = 0; y < 128; ++y) {
    for (int x = 0; x < 40; ++x) region(x, y) = 0;
  }
  PhotometricSolverInput input = InputFor(velvet);
  input.region = &region;
  PhotometricSolution one, two;
  PhotometricSolverOptions options;
  options.num_threads = 1;
  const PhotometricSolverSummary summary = SolvePhotometricStereo(options, input, &one);
  options.num_threads = 2;
  SolvePhotometricStereo(options, input, &two);
  ExpectAllFinite(one);
  EXPECT_GT(summary.pixels_coherent_sheen, 0u);
  EXPECT_TRUE(SameSolution(one, two));
  for (int y = 0; y < 128; ++y) {
    for (int x = 0; x < 40; ++x) {
      ASSERT_EQ(one.status(x, y), uint8_t(PixelStatus::kOutsideRegion));
      ASSERT_EQ(one.normal_in_table(x, y, 2), 1.0f);
    }
  }
  const double error = AngularErrorDegrees(one.normal_in_table, velvet.normal_in_table, region).mean;
  EXPECT_LT(error, 1.0);

  // Above max_lights: skipped, nothing changed.
  CoherentSheenOptions few;
  few.max_lights = 9;
  PhotometricSolution copy = one;
  const CoherentSheenSummary skipped = RefineCoherentSheen(few, options, input, &copy);
  EXPECT_TRUE(skipped.skipped_lights);
  EXPECT_TRUE(SameSolution(copy, one));
}

TEST(CoherentSheen, CancelLeavesAUsableSolution) {
  SyntheticScene velvet = MakeSyntheticScene(SphereOptions());
  AddSheen(kSheenF0, kSheenWidth, false, &velvet);
  PhotometricSolverOptions options;
  options.adaptive_coherent_sheen = false;
  PhotometricSolution solution;
  SolvePhotometricStereo(options, InputFor(velvet), &solution);
  const CoherentSheenSummary summary = RefineCoherentSheen(CoherentSheenOptions(), options, InputFor(velvet), &solution,
                                                           [](double fraction) { return fraction < 0.01; });
  EXPECT_TRUE(summary.IsCancelled());
  ExpectAllFinite(solution);
}

TEST(CoherentSheen, RejectsBadOptionsAndInputs) {
  auto throws = [](auto change) {
    CoherentSheenOptions options;
    change(&options);
    EXPECT_THROW(options.Check(), std::invalid_argument);
  };
  throws([](CoherentSheenOptions* o) { o->block_size = 2; });
  throws([](CoherentSheenOptions* o) { o->min_pixels = 4; });
  throws([](CoherentSheenOptions* o) { o->max_fit_pixels = 0; });
  throws([](CoherentSheenOptions* o) { o->iterations = 0; });
  throws([](CoherentSheenOptions* o) { o->min_width = 3; });
  throws([](CoherentSheenOptions* o) { o->max_width = 20; });
  throws([](CoherentSheenOptions* o) { o->min_residual_drop = 1; });
  throws([](CoherentSheenOptions* o) { o->gate_ratio = -0.1; });
  throws([](CoherentSheenOptions* o) { o->gate_ratio = 1; });
  throws([](CoherentSheenOptions* o) { o->bic_penalty = -1; });
  throws([](CoherentSheenOptions* o) { o->white_margin = 0; });
  throws([](CoherentSheenOptions* o) { o->max_lobe_fraction = std::nan(""); });
  throws([](CoherentSheenOptions* o) { o->num_threads = -1; });
  const SyntheticScene scene = MakeSyntheticScene(SphereOptions());
  PhotometricSolution wrong;
  wrong.normal_in_table = ImageF(8, 8, 3);
  EXPECT_THROW(RefineCoherentSheen(CoherentSheenOptions(), PhotometricSolverOptions(), InputFor(scene), &wrong),
               std::invalid_argument);
  EXPECT_THROW(RefineCoherentSheen(CoherentSheenOptions(), PhotometricSolverOptions(), InputFor(scene), nullptr),
               std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
