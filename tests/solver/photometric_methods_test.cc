// The method table: one row per method in the enum's order, names that round-trip,
// the light sharing and passes each method had before the table, and passes
// that are what a solve runs.
#include "solver/photometric_methods.h"

#include <set>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "solver/synthetic_scene.h"
#include "tests/solver/solver_test_util.h"

namespace scanbench {
namespace {

using Method = PhotometricSolverOptions::Method;
using ::testing::HasSubstr;
using testing::InputFor;

TEST(PhotometricMethodsTest, EveryMethodIsInTheTableOnceInTheEnumsOrder) {
  const auto rows = PhotometricMethods();
  ASSERT_EQ(rows.size(), 9u);
  std::set<std::string> names;
  for (size_t i = 0; i < rows.size(); ++i) {
    const PhotometricMethodRow& row = rows[i];
    EXPECT_EQ(static_cast<size_t>(row.method), i) << row.name;
    EXPECT_EQ(&PhotometricMethodRowOf(row.method), &row) << row.name;
    EXPECT_TRUE(names.insert(row.name).second) << row.name << " twice";
    EXPECT_NE(row.make_kernel, nullptr) << row.name;
    const std::string description = row.description;
    EXPECT_FALSE(description.empty()) << row.name;
    EXPECT_EQ(description.find('\n'), std::string::npos) << row.name << ": one line";
    std::set<SolverPass> passes;
    for (const MethodPass& pass : row.passes) {
      EXPECT_TRUE(passes.insert(pass.pass).second) << row.name << " lists a pass twice";
      EXPECT_EQ(pass.option == nullptr, pass.option_name == nullptr) << row.name;
    }
  }
  std::vector<Method> methods;
  for (const PhotometricMethodRow& row : rows) methods.push_back(row.method);
  EXPECT_EQ(AllPhotometricMethods(), methods);
}

TEST(PhotometricMethodsTest, NamesRoundTripAndTheNamesAreThoseOfBefore) {
  for (const PhotometricMethodRow& row : PhotometricMethods()) {
    EXPECT_EQ(PhotometricMethodFromName(row.name), row.method) << row.name;
    EXPECT_STREQ(PhotometricMethodName(row.method), row.name);
  }
  EXPECT_STREQ(PhotometricMethodName(Method::kAdaptive), "adaptive");
  EXPECT_STREQ(PhotometricMethodName(Method::kUniformPseudoInverse), "uniform_pinv");
  EXPECT_STREQ(PhotometricMethodName(Method::kDiffuseLobe), "diffuse_lobe");
  EXPECT_THAT([] { PhotometricMethodFromName("svd"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("'svd' is not one of adaptive, jacobi_svd, normal_equations, qr, uniform_pinv, "
                            "robust_irls, sparse_bayesian, diffuse_lobe, learned")));
  EXPECT_EQ(PhotometricSolverOptions().method, Method::kAdaptive) << "the default is adaptive";
}

TEST(PhotometricMethodsTest, AValueWithoutARowIsRefusedByName) {
  PhotometricSolverOptions options;
  options.method = static_cast<Method>(PhotometricMethods().size());
  EXPECT_THAT([&] { options.Check(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr(
                                            "PhotometricSolverOptions.method = 9 has no row in the method table")));
}

TEST(PhotometricMethodsTest, LightSharingAsBefore) {
  for (const PhotometricMethodRow& row : PhotometricMethods()) {
    const LightSharing expected = row.method == Method::kAdaptive               ? LightSharing::kWithinTolerance
                                  : row.method == Method::kUniformPseudoInverse ? LightSharing::kAlways
                                                                                : LightSharing::kNever;
    EXPECT_EQ(row.light_sharing, expected) << row.name;
    EXPECT_EQ(NeedsUniformLightField(row), row.method == Method::kUniformPseudoInverse) << row.name;
  }
}

// What the solver, the kernels and the solve job decided per method before the table.
TEST(PhotometricMethodsTest, PassesAsBefore) {
  for (const PhotometricMethodRow& row : PhotometricMethods()) {
    for (bool lobe : {false, true}) {
      for (bool coherent_lobe : {false, true}) {
        for (bool sheen : {false, true}) {
          for (bool coherent_sheen : {false, true}) {
            PhotometricSolverOptions options;
            options.method = row.method;
            options.adaptive_lobe = lobe;
            options.adaptive_coherent_lobe = coherent_lobe;
            options.adaptive_sheen = sheen;
            options.adaptive_coherent_sheen = coherent_sheen;
            const bool adaptive = row.method == Method::kAdaptive;
            SCOPED_TRACE(std::string(row.name) + " lobe " + std::to_string(lobe) + " coherent_lobe " +
                         std::to_string(coherent_lobe) + " sheen " + std::to_string(sheen) + " coherent_sheen " +
                         std::to_string(coherent_sheen));
            EXPECT_EQ(MethodRunsPass(options, SolverPass::kPixelLobe),
                      row.method == Method::kDiffuseLobe || (adaptive && lobe));
            EXPECT_EQ(MethodRunsPass(options, SolverPass::kPixelSheen), adaptive && sheen);
            EXPECT_EQ(MethodRunsPass(options, SolverPass::kCoherentLobe), adaptive && lobe && coherent_lobe);
            EXPECT_EQ(MethodRunsPass(options, SolverPass::kCoherentSheen), adaptive && coherent_sheen);
            EXPECT_EQ(MethodRunsPass(options, SolverPass::kBayerBlend), adaptive);
          }
        }
      }
    }
  }
}

// The table's passes are what a solve runs: the specular maps where the
// per-pixel lobe runs, the shared sheen's map where that pass runs.
TEST(PhotometricMethodsTest, ASolveRunsThePassesOfItsRow) {
  SyntheticSceneOptions scene_options;
  scene_options.width = scene_options.height = 32;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  for (const PhotometricMethodRow& row : PhotometricMethods()) {
    for (bool lobe : {false, true}) {
      PhotometricSolverOptions options;
      options.method = row.method;
      options.adaptive_lobe = lobe;
      PhotometricSolution solution;
      const PhotometricSolverSummary summary = SolvePhotometricStereo(options, InputFor(scene), &solution);
      ASSERT_EQ(summary.termination, Termination::kSuccess) << row.name << ": " << summary.BriefReport();
      EXPECT_EQ(summary.method, row.name);
      EXPECT_EQ(solution.specular.empty(), !MethodRunsPass(options, SolverPass::kPixelLobe)) << row.name;
      EXPECT_EQ(solution.coherent_sheen.empty(), !MethodRunsPass(options, SolverPass::kCoherentSheen)) << row.name;
    }
  }
}

}  // namespace
}  // namespace scanbench
