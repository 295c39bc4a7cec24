// Internal to the solver library: how the pixels of one tile get their lights.
// A tile shares one set of lights where the light field is uniform over it,
// takes them interpolated between a grid of nodes where that is within
// light_tolerance, and evaluates them at every pixel otherwise.
#pragma once

#include <vector>

#include "solver/tiled_solve.h"

namespace scanbench::tiled {

// Spacing of the nodes the light field is interpolated between, pixels. The
// bilinear error shrinks with its square: 16 px keeps the near-field rig's
// lights within 1e-4 at a quarter of the sensor's resolution.
inline constexpr int kLightCell = 16;

// Samples of the light field at one point: 3 per light.
struct LightProbe {
  std::vector<float> dirs, intensities;
  std::vector<float> inv;  // 1 / intensity, 0 where the light is unusable
  bool finite = true;
  bool usable = true;      // every light usable (positive, above min_light_intensity)
};

// Per thread: the light field as one tile needs it.
class TileLightSampler {
 public:
  explicit TileLightSampler(const SolveJob& job);

  // How the lights of the tile [x0, x1) x [y0, y1) reach its pixels, as far
  // as `sharing` allows. For kUniform, shared() holds them afterwards.
  TileLights Classify(LightSharing sharing, int x0, int y0, int x1, int y1);
  // The lights of row y, x0 to x1, into `buffers` (dir, inv, light_bad,
  // all_lights_condition) for a tile classified `lights`.
  void FillRow(TileLights lights, int x0, int x1, int y, SpanBuffers* buffers);
  const SharedLights& shared() const { return shared_; }

  // The light field at (x, y): directions, intensities and their usability
  // under the job's layout and min_light_intensity.
  void Probe(int x, int y, LightProbe* probe) const;

 private:
  void Resize(LightProbe* probe) const;
  TileLights ShareCentreLights();
  bool ProbeNodes(int x0, int y0, int x1, int y1);
  bool Differs(const LightProbe& a, const std::vector<float>& dirs, const std::vector<float>& inv) const;
  bool NodesMatchCentre() const;
  bool InterpolationHolds();
  void ComputeNodeConditions();
  void FillInterpolatedRow(int x0, int y, SpanBuffers* buffers);
  void FillExactRow(int x0, int x1, int y, SpanBuffers* buffers);

  const SolveJob& job_;
  const PhotometricSolverOptions& options_;
  const int num_lights_;
  std::vector<int> node_x_, node_y_;          // node coordinates, kLightCell apart
  std::vector<LightProbe> nodes_;             // the light field at the nodes
  std::vector<double> node_condition_;        // condition number of all lights at each node
  LightProbe centre_, interpolated_, truth_;
  // FillInterpolatedRow's arguments to the kernel: per cell, per node column, scratch.
  std::vector<int> cell_begin_, cell_count_;
  std::vector<double> cell_scale_;
  std::vector<const float*> column_rows_;
  std::vector<double> interpolate_scratch_;
  SharedLights shared_;
};

}  // namespace scanbench::tiled
