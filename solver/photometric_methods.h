// The method table: one row per PhotometricSolverOptions::Method, the one
// place that says what a method is called, what it is for, how far its tiles
// may share lights, which passes besides its per-pixel kernel it runs and
// which kernel that is. The solver, the CLI's --method, the GUI's method list,
// the solver report and the docs' method table (checked by
// tests/docs/solver_methods_docs_test.cc) all read it.
//
// Adding a method: its enumerator and its row (photometric_methods.cc), its
// fit (pixel_solvers.h) with the kernel factory that runs it (pixel_kernels.h;
// a per-pixel fit is MakePerPixelKernel over it), and its test.
#pragma once

#include <cstdint>
#include <memory>
#include <span>

#include "solver/photometric_solver.h"

namespace scanbench {
namespace tiled {
class PixelKernel;
struct SolveJob;
}  // namespace tiled

// What a method allows the light sampler (solver/tile_lights.h) to do with a tile.
enum class LightSharing {
  kNever,            // exact lights at every pixel
  kAlways,           // the tile centre's lights for the whole tile: needs a uniform light field
  kWithinTolerance,  // shared or interpolated where within light_tolerance
};

// The passes of a solve besides the per-pixel kernel's plain fit.
enum class SolverPass : uint8_t {
  kPixelLobe,      // per-pixel diffuse + GGX lobe fit (FitDiffuseLobe): fills the specular maps
  kPixelSheen,     // per-pixel diffuse + velvet sheen fit where the residual has its pattern (FitDiffuseSheen)
  kCoherentLobe,   // one anisotropic lobe shared per block (RefineCoherentLobe); RGB input, needs kPixelLobe
  kCoherentSheen,  // one velvet sheen shared per block and albedo group (RefineCoherentSheen); few lights
  kBayerBlend,     // RAW sessions: normals blended with a Bayer-domain solve's (BandedSolveOptions::bayer_blend)
  kLearnedNormals, // the learned network's normals (solver/normal_network.h): the learned kernel, the default's flagged pixels
};

// A pass a method runs, and the option that turns it on.
struct MethodPass {
  SolverPass pass;
  bool PhotometricSolverOptions::*option = nullptr;  // null: no solver option turns it off
  const char* option_name = nullptr;                // the option's field name (docs, tests)
};

// Builds the method's kernel with its own scratch for spans of up to
// `capacity` pixels: one per thread.
using PixelKernelFactory = std::unique_ptr<tiled::PixelKernel> (*)(const tiled::SolveJob& job, int capacity);

struct PhotometricMethodRow {
  PhotometricSolverOptions::Method method;
  const char* name;         // what --method, reports and result folders call it
  const char* description;  // one line for the operator (--method's help, the GUI)
  LightSharing light_sharing;
  std::span<const MethodPass> passes;
  PixelKernelFactory make_kernel;
};

// Every row, in the enum's order (the order the CLI, the GUI, the solver
// report and the docs list them).
std::span<const PhotometricMethodRow> PhotometricMethods();

// The row of `method`; throws std::invalid_argument for a value that has none.
const PhotometricMethodRow& PhotometricMethodRowOf(PhotometricSolverOptions::Method method);

// Whether a solve with `options` runs `pass` as far as its method and options
// decide: the method's row lists it and its option, if any, is on (the
// shared lobe also needs the per-pixel lobe's maps). What the input decides
// (RGB or Bayer, the number of lights, a RAW session) is left to the caller.
bool MethodRunsPass(const PhotometricSolverOptions& options, SolverPass pass);

// Whether the method refuses a light field that is not uniform over the
// image: it shares the centre's lights everywhere (LightSharing::kAlways).
bool NeedsUniformLightField(const PhotometricMethodRow& row);

}  // namespace scanbench
