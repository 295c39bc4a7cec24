#include "pipeline/relighting_check.h"

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"

namespace scanbench {
namespace {

// The pixels the check fits and scores: every step-th row and column of `pixels`.
ImageU8 ScoredPixels(const ImageU8& pixels, int step) {
  ImageU8 scored(pixels.width(), pixels.height(), 1);
  for (int y = 0; y < pixels.height(); y += step) {
    for (int x = 0; x < pixels.width(); x += step) scored(x, y) = pixels(x, y) != 0;
  }
  return scored;
}

// The pixels of `scored` that both fits gave a material.
ImageU8 FittedByBoth(const ImageU8& scored, const ClothMaterialMaps& a, const ClothMaterialMaps& b) {
  ImageU8 both(scored.width(), scored.height(), 1);
  for (size_t i = 0; i < scored.size(); ++i) {
    both.data()[i] = scored.data()[i] != 0 && (a.terms.data()[i] & kMaterialFitted) != 0 &&
                     (b.terms.data()[i] & kMaterialFitted) != 0;
  }
  return both;
}

}  // namespace

void RelightingCheckOptions::Check() const {
  fit.Check();
  SCANBENCH_REQUIRE_GE_LE("RelightingCheckOptions", "pixel_step", pixel_step, 1, 64);
}

double RelightingCheckSummary::Ratio() const {
  return lambertian_error > 0 ? material_error / lambertian_error : 0.0;
}

std::string RelightingCheckSummary::BriefReport() const {
  std::ostringstream out;
  out << "relighting: " << TerminationName(termination) << ", material "
      << Significant(100 * material_error, 3) << " %, Lambertian " << Significant(100 * lambertian_error, 3)
      << " % (ratio " << Significant(Ratio(), 3) << ") over " << pixels_scored << " px, " << lights.size()
      << " lights";
  if (!message.empty()) out << "; " << message;
  return out.str();
}

RelightingCheckSummary CheckRelighting(const RelightingCheckOptions& options, const PhotometricSolverInput& input,
                                       const ImageF& normals, const ImageU8& pixels,
                                       const ProgressCallback& progress) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  if (input.light_field == nullptr) throw std::invalid_argument("CheckRelighting: input.light_field is null");
  const int num_lights = input.light_field->num_lights();
  const ImageU8 scored = ScoredPixels(pixels, options.pixel_step);
  RelightingCheckSummary summary;
  for (size_t i = 0; i < scored.size(); ++i) summary.pixels_scored += scored.data()[i] != 0;
  double material_sum = 0, lambertian_sum = 0;
  int lights_with_samples = 0;
  for (int light = 0; light < num_lights; ++light) {
    const auto part = [&](int step) -> ProgressCallback {
      if (!progress) return {};
      return [&, step](double f) { return progress((2.0 * light + step + f) / (2.0 * num_lights)); };
    };
    ClothMaterialFitOptions fit = options.fit;
    fit.held_out_light = light;
    ClothMaterialMaps material, lambertian;
    const ClothMaterialFitSummary fitted = FitClothMaterial(fit, input, normals, scored, &material, part(0));
    fit.fit_sheen = fit.fit_specular = false;
    const ClothMaterialFitSummary albedo = FitClothMaterial(fit, input, normals, scored, &lambertian, part(1));
    if (fitted.IsCancelled() || albedo.IsCancelled()) {
      summary.SetCancelled("cancelled at light " + std::to_string(light + 1) + " of " + std::to_string(num_lights));
      return summary;
    }
    const ImageU8 both = FittedByBoth(scored, material, lambertian);
    const RelightingLightError error = ScoreLightPrediction(
        PredictLightImage(material, normals, *input.light_field, light, options.fit.num_threads),
        PredictLightImage(lambertian, normals, *input.light_field, light, options.fit.num_threads),
        *input.images[light], both, input.sample_valid.empty() ? nullptr : input.sample_valid[light]);
    if (error.samples > 0) {
      material_sum += error.material;
      lambertian_sum += error.lambertian;
      ++lights_with_samples;
    }
    summary.lights.push_back(error);
  }
  if (lights_with_samples > 0) {
    summary.material_error = material_sum / lights_with_samples;
    summary.lambertian_error = lambertian_sum / lights_with_samples;
    summary.termination = Termination::kSuccess;
  } else {
    summary.SetFailure("no scored pixel has a valid sample of any light");
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

RelightingLightError ScoreLightPrediction(const ImageF& material, const ImageF& lambertian, const ImageF& captured,
                                          const ImageU8& pixels, const ImageU8* sample_valid) {
  const auto fits = [&](const ImageF& image) { return image.SameSize(captured) && image.channels() == 3; };
  if (!fits(material) || !fits(lambertian) || !fits(captured) || !pixels.SameSize(captured)) {
    throw std::invalid_argument("ScoreLightPrediction: the predictions, the captured image (3 channels) and the "
                                "pixels must be the same size");
  }
  double material_sum = 0, lambertian_sum = 0, captured_sum = 0;
  RelightingLightError error;
  for (int y = 0; y < captured.height(); ++y) {
    for (int x = 0; x < captured.width(); ++x) {
      if (pixels(x, y) == 0 || (sample_valid && (*sample_valid)(x, y) == 0)) continue;
      bool finite = true;
      for (int c = 0; c < 3; ++c) finite = finite && std::isfinite(captured(x, y, c));
      if (!finite) continue;
      for (int c = 0; c < 3; ++c) {
        material_sum += std::abs(material(x, y, c) - captured(x, y, c));
        lambertian_sum += std::abs(lambertian(x, y, c) - captured(x, y, c));
        captured_sum += std::abs(captured(x, y, c));
      }
      ++error.samples;
    }
  }
  if (captured_sum > 0) {
    error.material = material_sum / captured_sum;
    error.lambertian = lambertian_sum / captured_sum;
  } else {
    error.samples = 0;
  }
  return error;
}

ImageF PredictLightImage(const ClothMaterialMaps& maps, const ImageF& normals, const LightField& light_field,
                         int light, int num_threads) {
  if (light < 0 || light >= light_field.num_lights()) {
    throw std::invalid_argument("PredictLightImage: light " + std::to_string(light) + " is not one of the field's " +
                                std::to_string(light_field.num_lights()));
  }
  const int width = light_field.width(), height = light_field.height(), num_lights = light_field.num_lights();
  if (!normals.SameSize(width, height) || !maps.terms.SameSize(width, height)) {
    throw std::invalid_argument("PredictLightImage: the normals and the material must be the light field's size");
  }
  ImageF image(width, height, 3);
  ParallelRows(height, num_threads, {}, 0, 1, [&](int y) {
    std::vector<float> dirs(3 * num_lights), intensities(3 * num_lights);
    for (int x = 0; x < width; ++x) {
      if ((maps.terms(x, y) & kMaterialFitted) == 0) continue;
      light_field.Evaluate(x, y, dirs.data(), intensities.data());
      float view[3];
      light_field.ViewDirection(x, y, view);
      const Eigen::Vector3d n(normals(x, y, 0), normals(x, y, 1), normals(x, y, 2));
      const Eigen::Vector3d l(dirs[3 * light], dirs[3 * light + 1], dirs[3 * light + 2]);
      const Eigen::Vector3d value = ClothMaterialValue(MaterialAt(maps, x, y), n, l, Eigen::Vector3d(view[0], view[1], view[2]));
      for (int c = 0; c < 3; ++c) image(x, y, c) = static_cast<float>(intensities[3 * light + c] * value(c));
    }
  });
  return image;
}

}  // namespace scanbench
