// The named steps of the tiled solve: how a tile's lights are classified and
// filled (tile_lights.h), and the tile loop on the shared ParallelFor (the
// result for any thread count, progress on the calling thread, a cancel
// midway).
#include <cmath>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "solver/photometric_methods.h"
#include "solver/photometric_solver.h"
#include "solver/pixel_kernels.h"
#include "solver/synthetic_scene.h"
#include "solver/tile_lights.h"
#include "tests/solver/solver_test_util.h"

namespace scanbench {
namespace {

using Method = PhotometricSolverOptions::Method;
using testing::InputFor;
using tiled::TileLights;

SyntheticScene SceneWith(SyntheticSceneOptions::Lights lights) {
  SyntheticSceneOptions options;
  options.lights = lights;
  return MakeSyntheticScene(options);
}

tiled::SolveJob JobFor(const SyntheticScene& scene, const PhotometricSolverOptions* options) {
  tiled::SolveJob job;
  job.options = options;
  job.field = scene.light_field.get();
  job.num_lights = scene.light_field->num_lights();
  return job;
}

TEST(TileLightSamplerTest, DistantLightsShareTheCentresLightsAndTheirMatrix) {
  const SyntheticScene scene = SceneWith(SyntheticSceneOptions::Lights::kDistant);
  const PhotometricSolverOptions options;
  const tiled::SolveJob job = JobFor(scene, &options);
  tiled::TileLightSampler sampler(job);
  ASSERT_EQ(sampler.Classify(LightSharing::kWithinTolerance, 0, 0, 64, 64), TileLights::kUniform);
  const int k = job.num_lights;
  std::vector<float> dirs(3 * k), intensities(3 * k);
  scene.light_field->Evaluate(31, 31, dirs.data(), intensities.data());
  Eigen::Matrix3d gram = Eigen::Matrix3d::Zero();
  for (int l = 0; l < k; ++l) {
    const Eigen::Vector3d d(dirs[3 * l], dirs[3 * l + 1], dirs[3 * l + 2]);
    gram += d * d.transpose();
    for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(sampler.shared().inv[3 * l + c], 1.0f / intensities[3 * l + c]);
  }
  const tiled::SharedLights& shared = sampler.shared();
  EXPECT_EQ(shared.usable, k);
  EXPECT_TRUE((shared.inverse * gram).isApprox(Eigen::Matrix3d::Identity(), 1e-9));
  EXPECT_NEAR(shared.condition, ConditionNumberFromGram(gram), 1e-9 * shared.condition);
}

TEST(TileLightSamplerTest, NearFieldLightsAreInterpolatedWithinTheTolerance) {
  const SyntheticScene scene = SceneWith(SyntheticSceneOptions::Lights::kNearField);
  const PhotometricSolverOptions options;
  const tiled::SolveJob job = JobFor(scene, &options);
  tiled::TileLightSampler sampler(job);
  const int x0 = 64, x1 = 128, y = 77;
  ASSERT_EQ(sampler.Classify(LightSharing::kWithinTolerance, x0, 64, x1, 128), TileLights::kInterpolated);
  tiled::SpanBuffers buffers(job.num_lights, 64);
  sampler.FillRow(TileLights::kInterpolated, x0, x1, y, &buffers);
  const int k = job.num_lights, n = buffers.capacity;
  std::vector<float> dirs(3 * k), intensities(3 * k);
  double worst_dir = 0, worst_inv = 0;
  for (int i = 0; i < x1 - x0; ++i) {
    scene.light_field->Evaluate(x0 + i, y, dirs.data(), intensities.data());
    ASSERT_EQ(buffers.light_bad[i], 0);
    for (int l = 0; l < k; ++l) {
      double dir2 = 0;
      for (int c = 0; c < 3; ++c) {
        const size_t at = static_cast<size_t>(3 * l + c) * n + i;
        dir2 += std::pow(buffers.dir[at] - dirs[3 * l + c], 2);
        const double inv = 1.0 / intensities[3 * l + c];
        worst_inv = std::max(worst_inv, std::abs(buffers.inv[at] - inv) / inv);
      }
      worst_dir = std::max(worst_dir, std::sqrt(dir2));
    }
  }
  EXPECT_LE(worst_dir, options.light_tolerance);
  EXPECT_LE(worst_inv, options.light_tolerance);
  EXPECT_GT(worst_dir, 0) << "the lights must vary over the tile for the test to mean anything";
}

TEST(TileLightSamplerTest, WhatTheMethodAllowsDecidesAndExactRowsAreTheField) {
  const SyntheticScene near = SceneWith(SyntheticSceneOptions::Lights::kNearField);
  const SyntheticScene distant = SceneWith(SyntheticSceneOptions::Lights::kDistant);
  PhotometricSolverOptions exact_only;
  exact_only.light_tolerance = 0;
  const PhotometricSolverOptions defaults;
  tiled::TileLightSampler near_exact(JobFor(near, &exact_only));
  EXPECT_EQ(near_exact.Classify(LightSharing::kWithinTolerance, 0, 0, 64, 64), TileLights::kExact);
  tiled::TileLightSampler near_default(JobFor(near, &defaults));
  EXPECT_EQ(near_default.Classify(LightSharing::kAlways, 0, 0, 64, 64), TileLights::kUniform);
  tiled::TileLightSampler distant_default(JobFor(distant, &defaults));
  EXPECT_EQ(distant_default.Classify(LightSharing::kNever, 0, 0, 64, 64), TileLights::kExact);

  // The methods' sharing: only adaptive and uniform_pinv share lights.
  for (const PhotometricMethodRow& method : PhotometricMethods()) {
    EXPECT_EQ(method.light_sharing != LightSharing::kNever,
              method.method == Method::kAdaptive || method.method == Method::kUniformPseudoInverse)
        << method.name;
  }

  const tiled::SolveJob job = JobFor(near, &defaults);
  tiled::TileLightSampler sampler(job);
  tiled::SpanBuffers buffers(job.num_lights, 32);
  sampler.FillRow(TileLights::kExact, 10, 42, 5, &buffers);
  std::vector<float> dirs(3 * job.num_lights), intensities(3 * job.num_lights);
  for (int i = 0; i < 32; ++i) {
    near.light_field->Evaluate(10 + i, 5, dirs.data(), intensities.data());
    for (int q = 0; q < 3 * job.num_lights; ++q) {
      ASSERT_EQ(buffers.dir[static_cast<size_t>(q) * 32 + i], dirs[q]);
      ASSERT_EQ(buffers.inv[static_cast<size_t>(q) * 32 + i], 1.0f / intensities[q]);
    }
  }
}

struct ThreadCase {
  Method method;
  SyntheticSceneOptions::Lights lights;
};

class ThreadCountTest : public ::testing::TestWithParam<ThreadCase> {};

// Every output, not only the normals, and every count of the summary.
TEST_P(ThreadCountTest, EveryOutputIsTheSameForOneAndThreeThreads) {
  SyntheticSceneOptions scene_options;
  scene_options.lights = GetParam().lights;
  scene_options.noise_stddev = 0.002;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolverOptions options;
  options.method = GetParam().method;
  options.tile_size = 32;
  options.num_threads = 1;
  PhotometricSolution one, three;
  const PhotometricSolverSummary one_summary = SolvePhotometricStereo(options, InputFor(scene), &one);
  options.num_threads = 3;
  const PhotometricSolverSummary three_summary = SolvePhotometricStereo(options, InputFor(scene), &three);
  EXPECT_EQ(one_summary.num_threads, 1);
  EXPECT_EQ(three_summary.num_threads, 3);
  EXPECT_EQ(one_summary.pixels_by_status, three_summary.pixels_by_status);
  EXPECT_EQ(one_summary.pixels_by_path, three_summary.pixels_by_path);
  auto same = [](const auto& a, const auto& b) {
    return a.size() == b.size() && std::equal(a.data(), a.data() + a.size(), b.data());
  };
  EXPECT_TRUE(same(one.normal_in_table, three.normal_in_table));
  EXPECT_TRUE(same(one.albedo, three.albedo));
  EXPECT_TRUE(same(one.status, three.status));
  EXPECT_TRUE(same(one.lights_used, three.lights_used));
  EXPECT_TRUE(same(one.condition_number, three.condition_number));
  EXPECT_TRUE(same(one.residual, three.residual));
  EXPECT_TRUE(same(one.solve_path, three.solve_path));
}

std::vector<ThreadCase> ThreadCases() {
  std::vector<ThreadCase> cases;
  for (Method method : AllPhotometricMethods()) {
    cases.push_back({method, SyntheticSceneOptions::Lights::kDistant});
    if (method != Method::kUniformPseudoInverse) cases.push_back({method, SyntheticSceneOptions::Lights::kNearField});
  }
  return cases;
}

INSTANTIATE_TEST_SUITE_P(Methods, ThreadCountTest, ::testing::ValuesIn(ThreadCases()),
                         [](const ::testing::TestParamInfo<ThreadCase>& param_info) {
                           return std::string(PhotometricMethodName(param_info.param.method)) +
                                  (param_info.param.lights == SyntheticSceneOptions::Lights::kDistant ? "_Distant"
                                                                                                 : "_NearField");
                         });

TEST(TileLoopTest, ProgressRunsOnTheCallingThreadAndACancelMidwayStopsTheTiles) {
  SyntheticSceneOptions scene_options;
  scene_options.width = scene_options.height = 512;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolverOptions options;
  options.tile_size = 32;  // 256 tiles
  options.num_threads = 2;
  const std::thread::id caller = std::this_thread::get_id();
  int calls = 0, calls_elsewhere = 0;
  PhotometricSolution solution;
  const PhotometricSolverSummary summary =
      SolvePhotometricStereo(options, InputFor(scene), &solution, [&](double fraction) {
        ++calls;
        calls_elsewhere += std::this_thread::get_id() != caller;
        return fraction == 0.0;  // stop after the first tile
      });
  EXPECT_EQ(calls_elsewhere, 0);
  EXPECT_EQ(calls, 2) << "once before any work, once after the caller's first tile";
  EXPECT_EQ(summary.termination, Termination::kCancelled);
  EXPECT_THAT(summary.message, ::testing::MatchesRegex("cancelled after [1-9][0-9]* of 256 tiles"));
  EXPECT_LT(summary.num_solved(), 512u * 512u / 2);
  EXPECT_GT(summary.num_solved(), 0u);
}

}  // namespace
}  // namespace scanbench
