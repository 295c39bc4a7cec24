// An analytic textile sample on the scan table: the ground truth that the
// simulated rig renders and that solver results are scored against.
//
// Everything is in the table frame (calibration/rig.h): millimetres, z up,
// origin at the centre of the sample. The sample is a height field
// z = HeightMm(x, y) >= 0 over a rectangle; outside it lies the flat table
// (z = 0). The field is C1 everywhere (the sample edge is blended down to the
// table), so NormalInTable is defined and continuous everywhere.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace scanbench {

enum class WeavePattern {
  kPlain,  // each warp goes over one weft, under the next
  kTwill,  // 2/2 twill: over two, under two, shifted one weft per warp (diagonal ribs)
};

struct TextileSceneOptions {
  uint64_t seed = 20240611;              // seeds thread-to-thread variation and the folds
  // Sample outline.
  double sample_width_mm = 120.0;        // extent along table x, > 0
  double sample_height_mm = 80.0;        // extent along table y, > 0
  double edge_blend_mm = 5.0;            // ramp from 0 at the edge to full height inside, (0, half the smaller extent]
  // Weave (warp threads run along y, weft threads along x). The default is a
  // coarse upholstery twill: about 20 px per thread in the default quarter-
  // resolution capture (0.116 mm/px), as many as a 1.2 mm denim weave gets at
  // the full 16 MP. Finer weaves at the quarter resolution are mostly
  // demosaicing error (see docs/simulated-rig.md).
  WeavePattern weave = WeavePattern::kTwill;
  double warp_pitch_mm = 2.4;            // warp spacing along x, > 0
  double weft_pitch_mm = 3.0;            // weft spacing along y, > 0
  double thread_height_mm = 0.22;        // crown of a thread above the cloth base, >= 0
  double crossing_amplitude_mm = 0.12;   // over/under undulation of a thread's crown, >= 0
  double thread_height_variation = 0.15; // relative per-thread random crown variation, [0, 1)
  double smoothing_mm = 0.03;            // soft-max length where warp meets weft (keeps normals continuous), > 0
  double base_thickness_mm = 0.3;        // cloth under the weave relief, >= 0
  // Folds: a sum of plane waves, lifting the cloth by 0 .. 2 * fold_amplitude_mm.
  double fold_amplitude_mm = 2.5;        // >= 0
  int num_fold_waves = 3;                // [0, 64]
  double fold_min_wavelength_mm = 25.0;  // > 0
  double fold_max_wavelength_mm = 60.0;  // >= fold_min_wavelength_mm
  // Albedo (linear RGB reflectance, each channel in [0, 1]).
  Eigen::Vector3d warp_rgb{0.10, 0.17, 0.50};   // indigo warp
  Eigen::Vector3d weft_rgb{0.78, 0.62, 0.34};   // ecru / ochre weft
  Eigen::Vector3d table_rgb{0.35, 0.35, 0.35};  // neutral grey table
  double color_variation = 0.08;         // relative per-thread albedo variation (and slubs along it), [0, 0.5]
  double gap_darkening = 0.3;            // relative albedo loss in the gaps between threads, [0, 1]

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

// Height, gradient and albedo at one point; what every query below computes.
struct SurfaceSample {
  double height_mm = 0;                            // z of the surface
  Eigen::Vector2d gradient = Eigen::Vector2d::Zero();  // (dz/dx, dz/dy), dimensionless
  Eigen::Vector3d albedo = Eigen::Vector3d::Zero();    // linear RGB, [0, 1]
};

class TextileScene {
 public:
  explicit TextileScene(const TextileSceneOptions& options = {});

  const TextileSceneOptions& options() const { return options_; }

  // Surface height above the table, mm; 0 off the sample.
  double HeightMm(double x_mm, double y_mm) const;
  // (dz/dx, dz/dy) of HeightMm, analytic.
  Eigen::Vector2d HeightGradient(double x_mm, double y_mm) const;
  // Unit upward normal (-dz/dx, -dz/dy, 1) / norm in the table frame; z > 0.
  Eigen::Vector3d NormalInTable(double x_mm, double y_mm) const;
  // Linear RGB albedo, each channel in [0, 1].
  Eigen::Vector3d Albedo(double x_mm, double y_mm) const;
  // Inside the sample rectangle (edges included).
  bool OnSample(double x_mm, double y_mm) const;
  // All of the above at once (one evaluation; what the renderer uses).
  SurfaceSample Sample(double x_mm, double y_mm, bool with_albedo = true) const;

  // Upper bound of HeightMm anywhere, mm.
  double MaxHeightMm() const { return max_height_mm_; }

 private:
  struct FoldWave {
    Eigen::Vector2d wave_vector;  // 2 pi * direction / wavelength, rad/mm
    double phase = 0;             // rad
    double weight = 0;            // weights sum to 1
  };

  SurfaceSample Evaluate(double x_mm, double y_mm, bool with_gradient, bool with_albedo) const;
  // The folds' height above the base at (x, y), mm; adds its gradient to
  // *gradient when given.
  double FoldHeightMm(double x_mm, double y_mm, Eigen::Vector2d* gradient) const;

  TextileSceneOptions options_;
  std::vector<FoldWave> folds_;
  double max_height_mm_ = 0;
};

}  // namespace scanbench
