// The solver's runtime CPU dispatch (solver/cpu_dispatch.h): every kernel
// variant this CPU runs gives the baseline's results on the same input, the
// override refuses what the CPU lacks, and the summary names the one that ran.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "solver/cpu_dispatch.h"
#include "solver/photometric_solver.h"
#include "solver/synthetic_scene.h"
#include "tests/solver/solver_test_util.h"

namespace scanbench {
namespace {

using Method = PhotometricSolverOptions::Method;
using ::testing::HasSubstr;

// Relative difference, with a floor so that values near 0 compare absolutely.
double Relative(double a, double b) { return std::abs(a - b) / std::max({std::abs(a), std::abs(b), 1e-3}); }

// Every map of `other` within `tolerance` (relative) of `baseline`, and the
// same status, path and light count at every pixel.
void ExpectSameSolution(const PhotometricSolution& baseline, const PhotometricSolution& other, double tolerance,
                        const std::string& what) {
  SCOPED_TRACE(what);
  ASSERT_EQ(baseline.status.size(), other.status.size());
  size_t solved = 0;
  for (size_t i = 0; i < baseline.status.size(); ++i) {
    ASSERT_EQ(baseline.status.data()[i], other.status.data()[i]) << "status at pixel " << i;
    ASSERT_EQ(baseline.solve_path.data()[i], other.solve_path.data()[i]) << "solve_path at pixel " << i;
    ASSERT_EQ(baseline.lights_used.data()[i], other.lights_used.data()[i]) << "lights_used at pixel " << i;
    solved += baseline.status.data()[i] == uint8_t(PixelStatus::kSolved);
  }
  EXPECT_GT(solved, baseline.status.size() / 2) << "the scene must be mostly solved for the test to mean anything";
  double worst = 0;
  for (const auto& [a, b] : {std::pair{&baseline.normal_in_table, &other.normal_in_table},
                             std::pair{&baseline.albedo, &other.albedo},
                             std::pair{&baseline.condition_number, &other.condition_number},
                             std::pair{&baseline.residual, &other.residual},
                             std::pair{&baseline.specular, &other.specular}}) {
    ASSERT_EQ(a->size(), b->size());
    for (size_t i = 0; i < a->size(); ++i) worst = std::max(worst, Relative(a->data()[i], b->data()[i]));
  }
  EXPECT_LE(worst, tolerance);
}

// The ISAs beyond the baseline that this CPU runs; the tests skip without one.
std::vector<KernelIsa> WiderIsas() {
  std::vector<KernelIsa> isas = SupportedKernelIsas();
  isas.erase(std::remove(isas.begin(), isas.end(), KernelIsa::kBaseline), isas.end());
  return isas;
}

// A near-field scene with noise, a specular highlight (so that adaptive's
// robust pass runs) and some samples marked clipped; its width is no
// multiple of the kernels' block, so that the spans' tails are compared too.
struct Scene {
  SyntheticScene scene;
  std::vector<ImageU8> valid;
};

Scene MakeScene(SyntheticSceneOptions::Lights lights) {
  SyntheticSceneOptions options;
  options.width = 203;
  options.height = 141;
  options.lights = lights;
  options.noise_stddev = 0.003;
  options.specular = 0.3;
  options.seed = 7;
  Scene s{MakeSyntheticScene(options), {}};
  std::mt19937 random(11);
  std::uniform_real_distribution<double> uniform(0, 1);
  for (size_t k = 0; k < s.scene.images.size(); ++k) {
    ImageU8 valid(options.width, options.height, 1, 1);
    for (size_t i = 0; i < valid.size(); ++i) valid.data()[i] = uniform(random) < 0.02 ? 0 : 1;
    s.valid.push_back(std::move(valid));
  }
  return s;
}

PhotometricSolverInput InputOf(const Scene& s) {
  PhotometricSolverInput input = testing::InputFor(s.scene);
  for (const ImageU8& valid : s.valid) input.sample_valid.push_back(&valid);
  return input;
}

// Forces the kernels of solves started in its lifetime.
class ScopedKernelIsa {
 public:
  explicit ScopedKernelIsa(KernelIsa isa) { OverrideKernelIsa(isa); }
  ~ScopedKernelIsa() { ClearKernelIsaOverride(); }
};

PhotometricSolution Solve(PhotometricSolverOptions options, const PhotometricSolverInput& input, KernelIsa isa) {
  const ScopedKernelIsa forced(isa);
  options.num_threads = 1;
  PhotometricSolution solution;
  const PhotometricSolverSummary summary = SolvePhotometricStereo(options, input, &solution);
  EXPECT_EQ(summary.kernel_isa, KernelIsaName(isa));
  EXPECT_THAT(summary.BriefReport(), HasSubstr(std::string(KernelIsaName(isa)) + " kernels"));
  return solution;
}

// Kernels built without contraction round every operation alike: the
// variants agree to the last bit in practice; 1e-6 relative is the promise.
constexpr double kTolerance = 1e-6;

TEST(CpuDispatchTest, EveryVariantGivesTheBaselinesResults) {
  if (WiderIsas().empty()) GTEST_SKIP() << "this CPU has no AVX2: only the baseline kernels run here";
  const Scene near = MakeScene(SyntheticSceneOptions::Lights::kNearField);
  const Scene distant = MakeScene(SyntheticSceneOptions::Lights::kDistant);
  struct Case {
    const char* name;
    Method method;
    const Scene* scene;
    bool albedo;
  };
  // The shared (uniform_pinv), interpolated (adaptive near field) and exact
  // (normal_equations) paths, with and without the RGB albedo sums.
  for (const Case& c : {Case{"adaptive near", Method::kAdaptive, &near, true},
                        Case{"adaptive distant", Method::kAdaptive, &distant, true},
                        Case{"uniform_pinv distant", Method::kUniformPseudoInverse, &distant, true},
                        Case{"normal_equations near", Method::kNormalEquations, &near, true},
                        Case{"normal_equations near, no albedo", Method::kNormalEquations, &near, false}}) {
    PhotometricSolverOptions options;
    options.method = c.method;
    options.compute_albedo = c.albedo;
    options.min_sample_value = 0.01;
    options.tile_size = 96;  // spans of 96 and 11 pixels: a full block and tails
    const PhotometricSolverInput input = InputOf(*c.scene);
    const PhotometricSolution baseline = Solve(options, input, KernelIsa::kBaseline);
    for (KernelIsa isa : WiderIsas()) {
      ExpectSameSolution(baseline, Solve(options, input, isa), kTolerance,
                         std::string(c.name) + ", " + KernelIsaName(isa));
    }
  }
}

// The interpolated-lights path by itself (adaptive's least squares in the
// near field, no robust re-solve, no sample marked clipped): its row fill,
// its condition numbers of shadowed pixels and the result writes of whole
// spans run in the per-ISA kernels. Every variant gives the baseline's maps,
// and most pixels took that path (else the test would not test it).
TEST(CpuDispatchTest, InterpolatedPathVariantsGiveTheBaselinesResults) {
  if (WiderIsas().empty()) GTEST_SKIP() << "this CPU has no AVX2: only the baseline kernels run here";
  const Scene near = MakeScene(SyntheticSceneOptions::Lights::kNearField);
  const PhotometricSolverInput input = testing::InputFor(near.scene);
  PhotometricSolverOptions options;
  options.method = Method::kAdaptive;
  options.adaptive_robust_residual = std::numeric_limits<double>::infinity();
  options.adaptive_coherent_lobe = false;
  options.adaptive_coherent_sheen = false;
  options.min_sample_value = 0.01;  // shadowed samples: pixels that use fewer than all lights
  options.tile_size = 96;
  PhotometricSolution baseline;
  PhotometricSolverSummary summary;
  {
    const ScopedKernelIsa forced(KernelIsa::kBaseline);
    summary = SolvePhotometricStereo(options, input, &baseline);
  }
  EXPECT_GT(summary.pixels_by_path[int(SolvePath::kInterpolatedLights)], summary.num_pixels / 2);
  size_t partly_lit = 0;
  for (size_t i = 0; i < baseline.status.size(); ++i) {
    partly_lit += baseline.status.data()[i] == uint8_t(PixelStatus::kSolved) && baseline.lights_used.data()[i] < 8;
  }
  EXPECT_GT(partly_lit, 100u) << "pixels with shadowed lights, whose condition numbers the kernel computes";
  for (KernelIsa isa : WiderIsas()) {
    ExpectSameSolution(baseline, Solve(options, input, isa), kTolerance,
                       std::string("adaptive near, least squares, ") + KernelIsaName(isa));
  }
}

// The point LEDs' span kernel (the exact path's light field) alone: every
// value of every variant equal to the baseline's, over the scene's field.
TEST(CpuDispatchTest, PointLightVariantsGiveTheBaselinesLights) {
  if (WiderIsas().empty()) GTEST_SKIP() << "this CPU has no AVX2: only the baseline kernels run here";
  const Scene near = MakeScene(SyntheticSceneOptions::Lights::kNearField);
  const LightField& field = *near.scene.light_field;
  const int width = field.width(), stride = width + 5, values = 3 * field.num_lights();
  auto evaluate = [&](KernelIsa isa, int y, std::vector<float>* dirs, std::vector<float>* intensities) {
    const ScopedKernelIsa forced(isa);
    dirs->assign(static_cast<size_t>(values) * stride, 0.0f);
    intensities->assign(static_cast<size_t>(values) * stride, 0.0f);
    field.EvaluateSpan(1, y, width - 1, stride, dirs->data(), intensities->data());
  };
  for (int y : {0, field.height() / 2, field.height() - 1}) {
    std::vector<float> base_dirs, base_intensities;
    evaluate(KernelIsa::kBaseline, y, &base_dirs, &base_intensities);
    for (KernelIsa isa : WiderIsas()) {
      std::vector<float> dirs, intensities;
      evaluate(isa, y, &dirs, &intensities);
      double worst = 0;
      for (size_t j = 0; j < dirs.size(); ++j) {
        worst = std::max({worst, Relative(base_dirs[j], dirs[j]), Relative(base_intensities[j], intensities[j])});
      }
      EXPECT_LE(worst, kTolerance) << KernelIsaName(isa) << ", row " << y;
    }
  }
}

TEST(CpuDispatchTest, BayerVariantsGiveTheBaselinesResults) {
  if (WiderIsas().empty()) GTEST_SKIP() << "this CPU has no AVX2: only the baseline kernels run here";
  const Scene near = MakeScene(SyntheticSceneOptions::Lights::kNearField);
  // RGGB mosaics of the RGB images.
  const std::array<int, 4> cfa = {0, 1, 1, 2};
  std::vector<ImageF> mosaics;
  for (const ImageF& image : near.scene.images) {
    ImageF mosaic(image.width(), image.height(), 1);
    for (int y = 0; y < image.height(); ++y) {
      for (int x = 0; x < image.width(); ++x) mosaic(x, y) = image(x, y, cfa[(y & 1) * 2 + (x & 1)]);
    }
    mosaics.push_back(std::move(mosaic));
  }
  BayerSolverInput input;
  for (const ImageF& mosaic : mosaics) input.mosaics.push_back(&mosaic);
  for (const ImageU8& valid : near.valid) input.sample_valid.push_back(&valid);
  input.cfa_channels = cfa;
  input.light_field = near.scene.light_field.get();
  for (Method method : {Method::kAdaptive, Method::kNormalEquations}) {
    PhotometricSolverOptions options;
    options.method = method;
    PhotometricSolution baseline;
    {
      const ScopedKernelIsa forced(KernelIsa::kBaseline);
      SolvePhotometricStereoBayer(options, input, &baseline);
    }
    for (KernelIsa isa : WiderIsas()) {
      const ScopedKernelIsa forced(isa);
      PhotometricSolution other;
      EXPECT_EQ(SolvePhotometricStereoBayer(options, input, &other).kernel_isa, KernelIsaName(isa));
      ExpectSameSolution(baseline, other, kTolerance,
                         std::string("Bayer ") + PhotometricMethodName(method) + ", " + KernelIsaName(isa));
    }
  }
}

TEST(CpuDispatchTest, NamesRoundTripAndTheOverrideRefusesWhatTheCpuLacks) {
  for (KernelIsa isa : {KernelIsa::kBaseline, KernelIsa::kAvx2, KernelIsa::kAvx512}) {
    KernelIsa parsed = KernelIsa::kBaseline;
    ASSERT_TRUE(KernelIsaFromName(KernelIsaName(isa), &parsed));
    EXPECT_EQ(parsed, isa);
  }
  KernelIsa unused;
  EXPECT_FALSE(KernelIsaFromName("sse9", &unused));
  EXPECT_TRUE(KernelIsaSupported(KernelIsa::kBaseline));
  EXPECT_TRUE(KernelIsaSupported(DefaultKernelIsa()));

  for (KernelIsa isa : {KernelIsa::kAvx2, KernelIsa::kAvx512}) {
    if (KernelIsaSupported(isa)) {
      EXPECT_NO_THROW(OverrideKernelIsa(isa));
      EXPECT_EQ(ActiveKernelIsa(), isa);
    } else {
      EXPECT_THAT([&] { OverrideKernelIsa(isa); },
                  ::testing::ThrowsMessage<std::invalid_argument>(
                      ::testing::AllOf(HasSubstr(KernelIsaName(isa)), HasSubstr("baseline"))));
    }
    ClearKernelIsaOverride();
  }
  EXPECT_EQ(ActiveKernelIsa(), DefaultKernelIsa());
  // Without an override a solve runs the default and says so.
  const Scene distant = MakeScene(SyntheticSceneOptions::Lights::kDistant);
  PhotometricSolution solution;
  const PhotometricSolverSummary summary =
      SolvePhotometricStereo(PhotometricSolverOptions(), InputOf(distant), &solution);
  EXPECT_EQ(summary.kernel_isa, KernelIsaName(DefaultKernelIsa()));
}

}  // namespace
}  // namespace scanbench
