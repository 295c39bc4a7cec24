#include "solver/bayer_normal_blend.h"

#include <cmath>
#include <random>

#include <Eigen/Dense>
#include <gtest/gtest.h>

namespace scanbench {
namespace {

constexpr int kSize = 96;
constexpr double kAlbedo = 0.5;
constexpr double kDeg = 180.0 / 3.14159265358979323846;

// Ten lights in two rings, like the rig's.
std::vector<Eigen::Vector3d> RingLights() {
  std::vector<Eigen::Vector3d> dirs;
  for (int k = 0; k < 10; ++k) {
    const double azimuth = 2 * 3.14159265358979323846 * k / 5 + (k >= 5 ? 0.6 : 0.0);
    const double elevation = k >= 5 ? 0.5 : 1.0;  // radians
    dirs.emplace_back(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                      std::sin(elevation));
  }
  return dirs;
}

struct Fit {
  Eigen::Vector3d normal;
  double residual;  // RMS relative to the albedo, as PhotometricSolution::residual
};

Fit LeastSquares(const std::vector<Eigen::Vector3d>& lights, const std::vector<double>& samples) {
  Eigen::MatrixXd l(lights.size(), 3);
  Eigen::VectorXd b(lights.size());
  for (size_t k = 0; k < lights.size(); ++k) l.row(k) = lights[k].transpose(), b[k] = samples[k];
  const Eigen::Vector3d scaled = l.colPivHouseholderQr().solve(b);
  const double rms = std::sqrt((l * scaled - b).squaredNorm() / lights.size());
  return {scaled.normalized(), rms / scaled.norm()};
}

// A raw capture of `truth` (unit normals per pixel), solved two ways: per
// pixel from its own noisy samples ("Bayer domain") and from the samples
// averaged over its 3 x 3 neighbourhood ("demosaiced": less noise, but the
// neighbours' normals mixed in).
struct TwoSolves {
  PhotometricSolution bayer, demosaiced;
};

void Store(PhotometricSolution* solution, int x, int y, const Fit& fit) {
  for (int c = 0; c < 3; ++c) solution->normal_in_table(x, y, c) = static_cast<float>(fit.normal[c]);
  solution->residual(x, y) = static_cast<float>(fit.residual);
  solution->status(x, y) = static_cast<uint8_t>(PixelStatus::kSolved);
  solution->lights_used(x, y) = 10;
}

TwoSolves Solve(const std::vector<Eigen::Vector3d>& truth, double noise, unsigned seed) {
  const std::vector<Eigen::Vector3d> lights = RingLights();
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0, noise);
  std::vector<std::vector<double>> samples(truth.size(), std::vector<double>(lights.size()));
  for (size_t i = 0; i < truth.size(); ++i) {
    for (size_t k = 0; k < lights.size(); ++k) samples[i][k] = kAlbedo * truth[i].dot(lights[k]) + gauss(rng);
  }
  TwoSolves solves;
  for (PhotometricSolution* s : {&solves.bayer, &solves.demosaiced}) {
    s->normal_in_table = ImageF(kSize, kSize, 3, 0.0f);
    s->residual = ImageF(kSize, kSize, 1, 0.0f);
    s->status = ImageU8(kSize, kSize, 1, uint8_t{0});
    s->lights_used = ImageU8(kSize, kSize, 1, uint8_t{0});
  }
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      Store(&solves.bayer, x, y, LeastSquares(lights, samples[y * kSize + x]));
      std::vector<double> mixed(lights.size(), 0.0);
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = std::clamp(x + dx, 0, kSize - 1), yy = std::clamp(y + dy, 0, kSize - 1);
          for (size_t k = 0; k < lights.size(); ++k) mixed[k] += samples[yy * kSize + xx][k] / 9;
        }
      }
      Store(&solves.demosaiced, x, y, LeastSquares(lights, mixed));
    }
  }
  return solves;
}

double MeanErrorDeg(const PhotometricSolution& solution, const std::vector<Eigen::Vector3d>& truth) {
  double sum = 0;
  for (int i = 0; i < kSize * kSize; ++i) {
    const Eigen::Vector3d n(solution.normal_in_table.data()[3 * i], solution.normal_in_table.data()[3 * i + 1],
                            solution.normal_in_table.data()[3 * i + 2]);
    sum += std::atan2(n.cross(truth[i]).norm(), n.dot(truth[i])) * kDeg;
  }
  return sum / truth.size();
}

// Normals tilted by up to `tilt_deg` at random per pixel (fibres), or a gentle dome.
std::vector<Eigen::Vector3d> Normals(double tilt_deg, bool per_pixel, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0, tilt_deg / kDeg);
  std::vector<Eigen::Vector3d> normals;
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      const double sx = per_pixel ? gauss(rng) : 0.3 * (x - kSize / 2.0) / kSize;
      const double sy = per_pixel ? gauss(rng) : 0.3 * (y - kSize / 2.0) / kSize;
      normals.push_back(Eigen::Vector3d(sx, sy, 1).normalized());
    }
  }
  return normals;
}

const DirectionalLightField& Field() {
  static const DirectionalLightField field(kSize, kSize, RingLights(),
                                           std::vector<Eigen::Vector3d>(10, Eigen::Vector3d(1, 1, 1)));
  return field;
}

TEST(BayerNormalBlendTest, TakesThePixelsOwnNormalWhereNeighboursDiffer) {
  const std::vector<Eigen::Vector3d> truth = Normals(1.5, true, 3);
  TwoSolves solves = Solve(truth, 0.002, 4);
  const double bayer = MeanErrorDeg(solves.bayer, truth), demosaiced = MeanErrorDeg(solves.demosaiced, truth);
  ASSERT_LT(bayer, demosaiced);  // the scene is what the test means it to be
  BayerNormalBlendOptions options;
  options.num_threads = 2;
  const BayerNormalBlendSummary summary = BlendBayerNormals(options, solves.bayer, Field(), &solves.demosaiced);
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  EXPECT_GT(summary.mean_weight, 0.6);
  EXPECT_EQ(summary.pixels_weighed, size_t(kSize * kSize));
  EXPECT_LT(MeanErrorDeg(solves.demosaiced, truth), 0.75 * demosaiced);
  EXPECT_LT(MeanErrorDeg(solves.demosaiced, truth), 1.05 * bayer);
}

TEST(BayerNormalBlendTest, KeepsTheLessNoisyNormalWhereTheSurfaceIsSmooth) {
  const std::vector<Eigen::Vector3d> truth = Normals(0, false, 3);
  TwoSolves solves = Solve(truth, 0.004, 5);
  const double bayer = MeanErrorDeg(solves.bayer, truth), demosaiced = MeanErrorDeg(solves.demosaiced, truth);
  ASSERT_LT(demosaiced, 0.5 * bayer);
  BayerNormalBlendOptions options;
  const BayerNormalBlendSummary summary = BlendBayerNormals(options, solves.bayer, Field(), &solves.demosaiced);
  ASSERT_TRUE(summary.IsUsable());
  EXPECT_LT(summary.mean_weight, 0.25);
  EXPECT_LT(MeanErrorDeg(solves.demosaiced, truth), 1.05 * demosaiced);
}

TEST(BayerNormalBlendTest, LeavesLobesAndUnsolvedPixelsAndRejectsBadMaps) {
  const std::vector<Eigen::Vector3d> truth = Normals(1.5, true, 3);
  TwoSolves solves = Solve(truth, 0.002, 4);
  solves.demosaiced.specular_status = ImageU8(kSize, kSize, 1, static_cast<uint8_t>(SpecularStatus::kUnsupported));
  solves.demosaiced.specular_status(10, 10) = static_cast<uint8_t>(SpecularStatus::kEstimated);
  solves.bayer.status(20, 20) = static_cast<uint8_t>(PixelStatus::kIllConditioned);
  const ImageF before = solves.demosaiced.normal_in_table;
  const BayerNormalBlendSummary summary =
      BlendBayerNormals(BayerNormalBlendOptions(), solves.bayer, Field(), &solves.demosaiced);
  ASSERT_TRUE(summary.IsUsable());
  for (const auto& [x, y] : {std::pair{10, 10}, std::pair{20, 20}}) {
    for (int c = 0; c < 3; ++c) EXPECT_EQ(solves.demosaiced.normal_in_table(x, y, c), before(x, y, c));
  }
  EXPECT_NE(solves.demosaiced.normal_in_table(11, 10, 0), before(11, 10, 0));
  EXPECT_GE(summary.pixels_kept, 2u);

  BayerNormalBlendOptions bad;
  bad.cell_size = 1;
  EXPECT_THROW(BlendBayerNormals(bad, solves.bayer, Field(), &solves.demosaiced), std::invalid_argument);
  solves.bayer.residual = ImageF();
  EXPECT_THROW(BlendBayerNormals(BayerNormalBlendOptions(), solves.bayer, Field(), &solves.demosaiced),
               std::invalid_argument);
}

// The Bayer solution left as a solve with `cells` as its region leaves it:
// kOutsideRegion elsewhere.
PhotometricSolution OnlyIn(const PhotometricSolution& bayer, const ImageU8& cells, int cell_size) {
  PhotometricSolution masked = bayer;
  const ImageU8 region = BayerBlendRegion(cells, cell_size, kSize, kSize);
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      if (region(x, y) != 0) continue;
      masked.status(x, y) = static_cast<uint8_t>(PixelStatus::kOutsideRegion);
      masked.lights_used(x, y) = 0;
    }
  }
  return masked;
}

// The gate (issue #14's budget): the Bayer-domain solve is wanted where the
// normals vary from pixel to pixel (fibres), not on a smooth surface whose
// weights the noise keeps at 0; the cells it leaves out keep the demosaiced
// normal and the others blend as without the gate, bit for bit.
TEST(BayerNormalBlendTest, SelectsTheCellsWhereTheNormalsVaryFromPixelToPixel) {
  BayerNormalBlendOptions options;
  options.num_threads = 2;
  const int cells_per_side = kSize / options.cell_size;
  for (const bool fibres : {true, false}) {
    SCOPED_TRACE(fibres ? "fibres" : "smooth dome");
    const std::vector<Eigen::Vector3d> truth = Normals(fibres ? 1.5 : 0, fibres, 3);
    const TwoSolves solves = Solve(truth, fibres ? 0.002 : 0.004, 4);
    const BayerBlendCellsSummary cells = SelectBayerBlendCells(options, solves.demosaiced, Field());
    ASSERT_TRUE(cells.IsUsable()) << cells.message;
    ASSERT_TRUE(cells.cells.SameSize(cells_per_side, cells_per_side));
    EXPECT_EQ(cells.blocks, size_t(cells_per_side * ((cells_per_side + 31) / 32)));
    size_t selected = 0;
    for (size_t i = 0; i < cells.cells.size(); ++i) selected += cells.cells.data()[i];
    EXPECT_EQ(cells.pixels_left_out, size_t(kSize * kSize) - selected * options.cell_size * options.cell_size);
    if (fibres) {
      EXPECT_EQ(cells.blocks_open, cells.blocks) << cells.BriefReport();
    } else {
      EXPECT_LT(cells.blocks_open, cells.blocks / 10 + 1) << cells.BriefReport();
    }

    PhotometricSolution ungated = solves.demosaiced, gated = solves.demosaiced;
    const BayerNormalBlendSummary all = BlendBayerNormals(options, solves.bayer, Field(), &ungated);
    const BayerNormalBlendSummary some =
        BlendBayerNormals(options, OnlyIn(solves.bayer, cells.cells, options.cell_size), Field(), &gated);
    ASSERT_TRUE(all.IsUsable() && some.IsUsable());
    EXPECT_EQ(some.pixels_weighed + cells.pixels_left_out, size_t(kSize * kSize));
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        const bool in = cells.cells(x / options.cell_size, y / options.cell_size) != 0;
        const ImageF& expected = in ? ungated.normal_in_table : solves.demosaiced.normal_in_table;
        for (int c = 0; c < 3; ++c) ASSERT_EQ(gated.normal_in_table(x, y, c), expected(x, y, c)) << x << ", " << y;
      }
    }
    // What the gate leaves out the ungated blend hardly took.
    EXPECT_LT(MeanErrorDeg(gated, truth), MeanErrorDeg(ungated, truth) + 0.002);
  }

  // Without the gate every cell with a pixel to weigh; with given weights the
  // cells given more than 0, exactly.
  const TwoSolves solves = Solve(Normals(0, false, 3), 0.004, 4);
  BayerNormalBlendOptions open = options;
  open.gate_ratio = 0;
  const BayerBlendCellsSummary every = SelectBayerBlendCells(open, solves.demosaiced, Field());
  EXPECT_EQ(every.blocks_open, every.blocks);
  EXPECT_EQ(every.pixels_left_out, 0u);
  ImageF weights(cells_per_side, cells_per_side, 1, 0.0f);
  weights(3, 5) = 0.25f;
  weights(20, 0) = 1.0f;
  BayerNormalBlendOptions given = options;
  given.cell_weights = &weights;
  const BayerBlendCellsSummary chosen = SelectBayerBlendCells(given, solves.demosaiced, Field());
  for (int y = 0; y < cells_per_side; ++y) {
    for (int x = 0; x < cells_per_side; ++x) EXPECT_EQ(chosen.cells(x, y), weights(x, y) > 0 ? 1 : 0);
  }
  EXPECT_EQ(chosen.pixels_left_out, size_t(kSize * kSize - 2 * 16));
  const ImageU8 region = BayerBlendRegion(chosen.cells, options.cell_size, kSize, kSize);
  EXPECT_EQ(region(12, 20), 1);
  EXPECT_EQ(region(15, 23), 1);
  EXPECT_EQ(region(16, 20), 0);
  EXPECT_EQ(region(81, 3), 1);

  BayerNormalBlendOptions bad = options;
  bad.gate_ratio = -1;
  EXPECT_THROW(SelectBayerBlendCells(bad, solves.demosaiced, Field()), std::invalid_argument);
  bad = options;
  bad.gate_block_cells = 0;
  EXPECT_THROW(SelectBayerBlendCells(bad, solves.demosaiced, Field()), std::invalid_argument);
  PhotometricSolution no_residual = solves.demosaiced;
  no_residual.residual = ImageF();
  EXPECT_THROW(SelectBayerBlendCells(options, no_residual, Field()), std::invalid_argument);
  EXPECT_THROW(BayerBlendRegion(chosen.cells, options.cell_size, kSize + 8, kSize), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
