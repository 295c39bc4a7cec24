#include "solver/photometric_methods.h"

#include <iterator>
#include <stdexcept>
#include <string>

#include "solver/pixel_kernels.h"

namespace scanbench {
namespace {

using Method = PhotometricSolverOptions::Method;
using Options = PhotometricSolverOptions;

// adaptive's passes, each behind its option (docs/solver.md describes them).
constexpr MethodPass kAdaptivePasses[] = {
    {SolverPass::kPixelLobe, &Options::adaptive_lobe, "adaptive_lobe"},
    {SolverPass::kPixelSheen, &Options::adaptive_sheen, "adaptive_sheen"},
    {SolverPass::kCoherentLobe, &Options::adaptive_coherent_lobe, "adaptive_coherent_lobe"},
    {SolverPass::kCoherentSheen, &Options::adaptive_coherent_sheen, "adaptive_coherent_sheen"},
    {SolverPass::kBayerBlend},
    {SolverPass::kLearnedNormals},  // behind adaptive_learned, a three-way option (MethodRunsPass)
};
// diffuse_lobe's per-pixel fit is the lobe fit.
constexpr MethodPass kDiffuseLobePasses[] = {{SolverPass::kPixelLobe}};
// learned's per-pixel fit is the network's.
constexpr MethodPass kLearnedPasses[] = {{SolverPass::kLearnedNormals}};

// One row per method, in the enum's order (checked below).
constexpr PhotometricMethodRow kMethods[] = {
    {Method::kAdaptive, "adaptive",
     "fast and accurate: shared light matrix where the light is uniform, robust re-solve only where the residual "
     "calls for it",
     LightSharing::kWithinTolerance, kAdaptivePasses, tiled::MakeAdaptiveKernel},
    {Method::kJacobiSvd, "jacobi_svd", "reference least squares, per-pixel SVD: slowest, most stable",
     LightSharing::kNever, {}, tiled::MakeJacobiSvdKernel},
    {Method::kNormalEquations, "normal_equations", "per-pixel 3x3 normal equations, closed form: fast",
     LightSharing::kNever, {}, tiled::MakeNormalEquationsKernel},
    {Method::kQr, "qr", "per-pixel Householder QR least squares", LightSharing::kNever, {}, tiled::MakeQrKernel},
    {Method::kUniformPseudoInverse, "uniform_pinv",
     "one pseudo-inverse for all pixels: distant lights only, refused otherwise", LightSharing::kAlways, {},
     tiled::MakeNormalEquationsKernel},
    {Method::kRobustIrls, "robust_irls",
     "robust per-pixel reweighting (Tukey): rejects shadows and highlights; slower", LightSharing::kNever, {},
     tiled::MakeRobustIrlsKernel},
    {Method::kSparseBayesian, "sparse_bayesian",
     "sparse Bayesian outlier model: most robust to shadows and highlights; slowest", LightSharing::kNever, {},
     tiled::MakeSparseBayesianKernel},
    {Method::kDiffuseLobe, "diffuse_lobe",
     "diffuse plus specular lobe per pixel: uses highlights and sheen, writes a specular map", LightSharing::kNever,
     kDiffuseLobePasses, tiled::MakeDiffuseLobeKernel},
    {Method::kLearned, "learned",
     "a network trained on the project's own renders reads each pixel's lights as a set: any light count, "
     "highlights, sheen and shadows; writes its expected error",
     LightSharing::kNever, kLearnedPasses, tiled::MakeLearnedKernel},
};

// Row i is method i: the lookup is an index, and a row out of place does not
// compile (a method without a row throws at its first use: Check()).
constexpr bool RowsInEnumOrder() {
  for (size_t i = 0; i < std::size(kMethods); ++i) {
    if (static_cast<size_t>(kMethods[i].method) != i || kMethods[i].make_kernel == nullptr) return false;
  }
  return true;
}
static_assert(RowsInEnumOrder(), "kMethods: one row per PhotometricSolverOptions::Method, in the enum's order");

}  // namespace

std::span<const PhotometricMethodRow> PhotometricMethods() { return kMethods; }

const PhotometricMethodRow& PhotometricMethodRowOf(Method method) {
  const size_t index = static_cast<size_t>(method);
  if (index >= std::size(kMethods)) {
    throw std::invalid_argument("PhotometricSolverOptions.method = " + std::to_string(index) +
                                " has no row in the method table (solver/photometric_methods.cc)");
  }
  return kMethods[index];
}

bool MethodRunsPass(const PhotometricSolverOptions& options, SolverPass pass) {
  // The shared lobe refines the per-pixel lobe's fits.
  if (pass == SolverPass::kCoherentLobe && !MethodRunsPass(options, SolverPass::kPixelLobe)) return false;
  // adaptive's network is behind a three-way option, not a flag.
  if (pass == SolverPass::kLearnedNormals && options.method == Method::kAdaptive) {
    return options.adaptive_learned != Options::LearnedUse::kNever;
  }
  for (const MethodPass& listed : PhotometricMethodRowOf(options.method).passes) {
    if (listed.pass == pass) return listed.option == nullptr || options.*listed.option;
  }
  return false;
}

bool NeedsUniformLightField(const PhotometricMethodRow& row) { return row.light_sharing == LightSharing::kAlways; }

const char* PhotometricMethodName(Method method) { return PhotometricMethodRowOf(method).name; }

std::vector<Method> AllPhotometricMethods() {
  std::vector<Method> methods;
  for (const PhotometricMethodRow& row : kMethods) methods.push_back(row.method);
  return methods;
}

Method PhotometricMethodFromName(const std::string& name) {
  std::string names;
  for (const PhotometricMethodRow& row : kMethods) {
    if (name == row.name) return row.method;
    names += std::string(names.empty() ? "" : ", ") + row.name;
  }
  throw std::invalid_argument("photometric method '" + name + "' is not one of " + names);
}

}  // namespace scanbench
