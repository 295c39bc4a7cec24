#include "app/cli/command_util.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>

#include "app/sim/sensor_color.h"
#include "solver/photometric_methods.h"

namespace scanbench {

namespace {

// --method's help: one line per row of the method table, the default named.
std::string MethodHelp(PhotometricSolverOptions::Method default_method) {
  size_t name_width = 0;
  for (const PhotometricMethodRow& row : PhotometricMethods()) name_width = std::max(name_width, std::strlen(row.name));
  std::string help = std::string("Solver method (default ") + PhotometricMethodName(default_method) + "):";
  for (const PhotometricMethodRow& row : PhotometricMethods()) {
    help += "\n" + std::string(row.name) + std::string(name_width - std::strlen(row.name) + 2, ' ') + row.description;
  }
  return help;
}

}  // namespace

void AddPhotometricSolverOptions(CLI::App& command, PhotometricSolverOptions& options) {
  command
      .add_option_function<std::string>(
          "--method", [&options](const std::string& name) { options.method = PhotometricMethodFromName(name); },
          MethodHelp(options.method))
      ->check([](const std::string& name) {
        try {
          PhotometricMethodFromName(name);
          return std::string();
        } catch (const std::exception& error) {
          return std::string(error.what());
        }
      });
  SetsField(command.add_option("--threads", options.num_threads, "Solver threads (0 = all cores)"),
            "PhotometricSolverOptions.num_threads")
      ->capture_default_str();
  SetsField(command.add_option("--shadow-level", options.min_sample_value,
                               "Samples at or below this linear value count as shadow and are left out (0 = keep all)"),
            "PhotometricSolverOptions.min_sample_value")
      ->capture_default_str();
  SetsField(command.add_option("--max-condition", options.max_condition_number,
                               "Flag pixels whose light matrix is worse conditioned than this"),
            "PhotometricSolverOptions.max_condition_number")
      ->capture_default_str();
  command
      .add_option_function<std::string>(
          "--robust-loss",
          [&options](const std::string& name) {
            options.robust_loss = name == "cauchy" ? PhotometricSolverOptions::RobustLoss::kCauchy
                                                   : PhotometricSolverOptions::RobustLoss::kTukey;
          },
          "Loss of the robust fits: tukey (default) or cauchy")
      ->check(CLI::IsMember({"tukey", "cauchy"}));
  SetsField(command.add_option("--tile-size", options.tile_size, "Tile side in pixels"),
            "PhotometricSolverOptions.tile_size")
      ->capture_default_str();
  SetsField(
      command.add_option("--robust-iterations", options.robust_max_iterations, "Iteration limit of the robust fits"),
      "PhotometricSolverOptions.robust_max_iterations")
      ->capture_default_str();
  SetsField(command.add_option("--robust-dark-fraction", options.robust_dark_fraction,
                               "Robust fits leave out samples darker than this fraction of the pixel's brightest"),
            "PhotometricSolverOptions.robust_dark_fraction")
      ->capture_default_str();
  SetsField(command.add_option("--robust-min-scale", options.robust_min_scale,
                               "Floor of the robust residual scale, relative to the albedo"),
            "PhotometricSolverOptions.robust_min_scale")
      ->capture_default_str();
  SetsField(command.add_option("--robust-trigger", options.adaptive_robust_residual,
                               "adaptive: re-solve robustly where the relative RMS residual is above this"),
            "PhotometricSolverOptions.adaptive_robust_residual")
      ->capture_default_str();
  command.add_flag(
      "--no-lobe", [&options](std::int64_t) { options.adaptive_lobe = false; },
      "adaptive: the robust pass is Tukey IRLS alone, without the diffuse + specular lobe fit "
      "(no specular map)");
  command.add_flag("--no-coherent-lobe", [&options](std::int64_t) { options.adaptive_coherent_lobe = false; },
                   "adaptive: no shared anisotropic lobe per block after the per-pixel lobe fits "
                   "(each pixel keeps its own isotropic lobe)");
  command.add_flag("--no-coherent-sheen", [&options](std::int64_t) { options.adaptive_coherent_sheen = false; },
                   "adaptive: no velvet sheen shared per block and albedo group after the per-pixel fits "
                   "(the least-squares pixels keep their Lambertian result)");
  command.add_option("--learned", options.adaptive_learned,
                     "adaptive, at most --learned-max-lights lights: where its robust pass runs, take the learned "
                     "network's normal: never (default), unsupported (where the lobe fit keeps no lobe) or flagged "
                     "(every pixel of the robust pass)")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, PhotometricSolverOptions::LearnedUse>{
              {"never", PhotometricSolverOptions::LearnedUse::kNever},
              {"unsupported", PhotometricSolverOptions::LearnedUse::kUnsupportedLobe},
              {"flagged", PhotometricSolverOptions::LearnedUse::kFlagged}},
          CLI::ignore_case))
      ->option_text("TEXT:{never,unsupported,flagged}");  // CLI11 cannot print the enum's names
  SetsField(command.add_option("--learned-max-lights", options.adaptive_learned_max_lights,
                               "adaptive: the network runs on solves of at most this many lights"),
            "PhotometricSolverOptions.adaptive_learned_max_lights")
      ->capture_default_str();
  command.add_flag("--learned-refine", options.learned_refine,
                   "learned and adaptive's network pixels: re-solve the network's normal by least squares on the "
                   "samples that agree with it (off by default: it helps Lambertian pixels only)");
  command.add_flag("--sheen", options.adaptive_sheen,
                   "adaptive: re-solve pixels whose least-squares residual carries a velvet sheen's pattern with "
                   "the diffuse + velvet sheen model (off by default: it fits noise on Lambertian scenes)");
}

void AddDepthRefinementOptions(CLI::App& command, DepthRefinementOptions& depth) {
  SetsField(command.add_option(
                "--depth-iterations", depth.max_iterations,
                "Depth-aware re-solves at most: integrate the height, move the surface points along the camera "
                "rays, re-evaluate the LEDs there, re-solve [1, 20]"),
            "DepthRefinementOptions.max_iterations")
      ->capture_default_str();
  SetsField(
      command.add_option("--depth-tolerance", depth.tolerance_mm,
                         "Depth refinement converged when 99 % of the surface points would move less than this, mm"),
      "DepthRefinementOptions.tolerance_mm")
      ->capture_default_str();
  SetsField(command.add_option("--depth-min-range", depth.min_height_range_mm,
                               "Refine only when the first pass's integrated height range (p99 - p1) exceeds this, mm"),
            "DepthRefinementOptions.min_height_range_mm")
      ->capture_default_str();
  SetsField(command.add_option(
                "--depth-anchor-percentile", depth.anchor_percentile,
                "Depth refinement: this percentile of the integrated height is put on the table plane (solve-dataset: "
                "on the plane at mean_distance.txt, where the search for the distance starts unless "
                "--no-depth-anchor-fit)"),
            "DepthRefinementOptions.anchor_percentile")
      ->capture_default_str();
  SetsField(command.add_option(
                "--depth-shadow-edge", depth.shadow_edge_radius_px,
                "Depth refinement: the re-solves leave out lit samples within this many pixels of a cast "
                "shadow of the same LED (demosaicing mixes lit and shadowed light there) [0, 10], 0 = keep them"),
            "DepthRefinementOptions.shadow_edge_radius_px")
      ->capture_default_str();
  command.add_flag(
      "--no-depth-refine", [&depth](std::int64_t) { depth.enabled = false; },
      "Keep every surface point on the first pass's plane (solve: the table; solve-dataset: the plane at "
      "mean_distance.txt)");
}

void AddSolveOptions(CLI::App& command, SolveOptions& options) {
  AddPhotometricSolverOptions(command, options.solver);
  SetsField(command.add_option("--label", options.run_label, "Label in the result folder name"),
            "SolveOptions.run_label")
      ->capture_default_str();
  command
      .add_option_function<std::string>(
          "--demosaic",
          [&options](const std::string& name) {
            options.develop.demosaic =
                name == "bilinear" ? RawDevelopOptions::Demosaic::kBilinear : RawDevelopOptions::Demosaic::kEdgeAware;
          },
          "Bayer interpolation: edge_aware (default) or bilinear")
      ->check(CLI::IsMember({"edge_aware", "bilinear"}));
  command.add_flag("--bayer-domain", options.bayer_domain,
                   "Solve the normals per raw pixel from its own CFA sample instead of on the demosaiced frames "
                   "(only the albedo is demosaiced; on cloth more accurate, on Lambertian scenes noisier)");
  command.add_flag("--bayer-blend,!--no-bayer-blend", options.bayer_blend,
                   "With --method adaptive, on by default: blend each pixel's normal between the demosaiced solve "
                   "and a Bayer-domain one (more accurate, most on cloth; about 2x the solve time); "
                   "--no-bayer-blend: the demosaiced solve alone");
  command.add_flag("--no-verify", [&options](std::int64_t) { options.verify_checksums = false; },
                   "Skip re-hashing the frames against session.json");
  command.add_flag("--float32-maps", options.float32_maps,
                   "Store the EXR maps as 32-bit float (zip) instead of half float (11-bit mantissa, about 3x "
                   "smaller); the PNGs are the same");
  command.add_option("--calibration", options.calibration_dir,
                     "Calibration set (scanbench calibrate ...) to take the lights and camera from")
      ->check(CLI::ExistingDirectory);
  AddDepthRefinementOptions(command, options.depth);  // issue #15: draped samples
  SetsField(command.add_option("--calibration-max-age", options.calibration_max_age_days,
                               "Warn when the calibration set is older than this many days"),
            {"SolveOptions.calibration_max_age_days", "CalibrationUseOptions.max_age_days"})
      ->capture_default_str();
  command
      .add_option_function<std::string>(
          "--albedo-color",
          [&options](const std::string& name) { options.albedo_color.source = AlbedoColorSourceFromName(name); },
          "Albedo colour: auto (the calibration set's colour calibration, else the RAW files' camera matrix), chart, "
          "camera-matrix, or none (white-balanced camera RGB)")
      ->check(CLI::IsMember({"auto", "chart", "camera-matrix", "none"}));
}

void AddCameraColorOption(CLI::App& command, SensorColorModel& color) {
  command
      .add_option_function<std::string>(
          "--camera-color", [&color](const std::string& name) { color = *SensorColorModelFromName(name); },
          "Simulated camera colour: d5100 (default: measured Nikon D5100 sensitivities under a white LED, not "
          "colorimetric, as a real camera) or srgb-primaries (an idealised camera: camera RGB = linear Rec.709)")
      ->check(CLI::IsMember({SensorColorModelName(SensorColorModel::kNikonD5100),
                             SensorColorModelName(SensorColorModel::kSrgbPrimaries)}));
}

void AddMaterialOption(CLI::App& command, SurfaceMaterial& material) {
  command
      .add_option_function<std::string>(
          "--material", [&material](const std::string& name) { material = *SurfaceMaterialFromName(name); },
          "Simulated textile material: lambert (default, diffuse only), cloth (a velvet-distribution cloth "
          "BRDF: sheen toward grazing light) or satin (an anisotropic gloss along the threads); ground truth is "
          "the diffuse albedo and the pixel-scale normal (on the threads the mean of the fibres' normals)")
      ->check(
          CLI::IsMember({SurfaceMaterialName(SurfaceMaterial::kLambert), SurfaceMaterialName(SurfaceMaterial::kCloth),
                         SurfaceMaterialName(SurfaceMaterial::kSatin)}));
}

}  // namespace scanbench
