// Leave-one-light-out relighting (issue #34): does the fitted material look
// right under a light it was not fitted to? For each light, the material is
// fitted from the other lights (FitClothMaterial with held_out_light) and
// that light's image rendered from it; beside it, what a Lambertian scan
// predicts (the same fit with neither sheen nor specular term: albedo x n.l,
// its albedo from the other lights too). Both predict at the same normals
// (the caller's, e.g. the solve's from every light), so the comparison is of
// the materials alone.
//
// The error of a prediction is relative: sum |predicted - captured| over the
// scored pixels' valid samples of the light and their colour channels,
// divided by the sum of the captured values.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/progress.h"
#include "core/summary.h"
#include "solver/cloth_material.h"
#include "solver/light_field.h"
#include "solver/photometric_solver.h"

namespace scanbench {

struct RelightingCheckOptions {
  ClothMaterialFitOptions fit;  // held_out_light is set by the check, light by light
  // Every pixel_step-th row and column of the pixels is fitted and scored, in
  // [1, 64] (the check fits twice per light: 2 keeps it to half a fit).
  int pixel_step = 2;
  void Check() const;
};

struct RelightingLightError {
  double material = 0;    // relative error of the fitted material's prediction
  double lambertian = 0;  // relative error of albedo x n.l
  size_t samples = 0;     // scored pixels with a valid sample of the light
};

struct RelightingCheckSummary : AlgorithmSummary {
  std::vector<RelightingLightError> lights;  // one per light of the input
  double material_error = 0;                 // mean over the lights with samples
  double lambertian_error = 0;
  size_t pixels_scored = 0;
  double seconds = 0;
  // material_error / lambertian_error (the "at most half"); 0 without samples.
  double Ratio() const;
  std::string BriefReport() const;
};

// Throws std::invalid_argument on bad options or shapes (FitClothMaterial's
// rules); a cancel through `progress` returns kCancelled.
RelightingCheckSummary CheckRelighting(const RelightingCheckOptions& options, const PhotometricSolverInput& input,
                                       const ImageF& normals, const ImageU8& pixels,
                                       const ProgressCallback& progress = {});

// What light `light` of `light_field` would read (3 channels, the light's
// intensity applied) from the material `maps` at `normals`: a prediction of
// its photograph. 0 where the material was not fitted.
ImageF PredictLightImage(const ClothMaterialMaps& maps, const ImageF& normals, const LightField& light_field,
                         int light, int num_threads = 0);

// The relative errors of two predictions of `captured` (3 channels each, its
// size) over the non-zero pixels of `pixels` whose `sample_valid` (optional,
// 1 channel) is non-zero. samples = 0 where there is nothing to score.
RelightingLightError ScoreLightPrediction(const ImageF& material, const ImageF& lambertian, const ImageF& captured,
                                          const ImageU8& pixels, const ImageU8* sample_valid = nullptr);

}  // namespace scanbench
