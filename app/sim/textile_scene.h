// An analytic textile sample on the scan table: the ground truth that the
// simulated rig renders and that solver results are scored against.
//
// Everything is in the table frame (calibration/rig.h): millimetres, z up,
// origin at the centre of the sample. The sample is a height field
// z = HeightMm(x, y) >= 0 over a rectangle; outside it lies the flat table
// (z = 0). The field is C1 everywhere (the sample edge is blended down to the
// table), so NormalInTable is defined and continuous everywhere.
//
// The sample is a woven textile (SampleKind::kTextile) or a ColorChecker
// Classic card (kColorChecker, issue #12): a flat card of 24 patches in a 6 x 4
// grid on a black surround, a few tenths of a mm thick with a blended edge,
// slightly glossy. Albedo is linear Rec.709 (D65) reflectance either way; a
// ColorChecker point also names its patch (SurfaceSample::spectral_patch), so
// that a spectral camera renders it from the patch's measured spectrum rather
// than from an upsampling of its Rec.709 colour.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "app/sim/cloth_brdf.h"

namespace scanbench {

enum class WeavePattern {
  kPlain,  // each warp goes over one weft, under the next
  kTwill,  // 2/2 twill: over two, under two, shifted one weft per warp (diagonal ribs)
};

enum class SampleKind {
  kTextile,       // the analytic weave below
  kColorChecker,  // a ColorChecker Classic card lying flat (the chart_* fields)
};

// The ColorChecker patch (index into ColorCheckerClassic(), chart order) at
// (u, v) mm from the centre of a 6 x 4 grid of `patch_mm` squares on a
// `pitch_mm` pitch, +v towards the top row (dark skin at the top left); -1 in
// the gaps and outside the grid.
int ColorCheckerPatchIndexAt(double u_mm, double v_mm, double patch_mm, double pitch_mm);

struct TextileSceneOptions {
  SampleKind sample = SampleKind::kTextile;
  uint64_t seed = 20240611;              // seeds thread-to-thread variation and the folds
  // Sample outline (kTextile; the ColorChecker card's follows from its grid).
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

  // Material of the textile (issue #13; app/sim/cloth_brdf.h). The table and
  // the ColorChecker card stay as they are. kLambert renders exactly as before.
  SurfaceMaterial material = SurfaceMaterial::kLambert;
  // Per-thread specular parameters before the per-thread variation.
  // Textile fibres are dielectrics: F0 = ((n - 1) / (n + 1))^2 with silk n ~
  // 1.54-1.56, polyester ~ 1.57-1.64 (birefringent), nylon ~ 1.53-1.57,
  // cotton (cellulose) ~ 1.53-1.58 gives 0.044-0.058 (docs/simulated-rig.md
  // names the sources); what differs between materials is the roughness.
  // kCloth (the seed's velvet sheen): a dielectric F0 as well; the velvet
  // width a is the seed's (Ashikhmin's) parameter.
  ThreadBrdf cloth_warp{0.050, 1.0, 1.0};   // polyester/nylon-like warp, velvet width a (roughness_across unused)
  ThreadBrdf cloth_weft{0.045, 0.8, 0.8};   // cotton-like weft
  // kSatin: long aligned floats are smooth ALONG the fibres (a cylinder's
  // normals spread only across it), so the GGX alpha along the thread is low
  // and the one across high; the warp floats (silk / polyester filament) are
  // the glossy face, the weft is rougher.
  ThreadBrdf satin_warp{0.050, 0.07, 0.30}; // white F0, GGX alpha along / across the thread
  ThreadBrdf satin_weft{0.045, 0.15, 0.40};
  double material_variation = 0.15;      // relative per-thread random variation of F0 and roughness, [0, 0.5]
  // Fibre-scale shading normal variation (kCloth, kSatin). Fibres are 10-30 um
  // across, below the pixel even at the full 16 MP (0.029 mm/px), so the
  // variation is NOT geometry: the ground truth leaves it out and the rig
  // integrates the response over each pixel's footprint (SimulatedRig). Each
  // fibre (fibre_diameter_mm wide, across its thread) is inclined out of the
  // thread surface along the thread by fibre_tilt_deg * sin(2 pi s /
  // fibre_wavelength_mm + its own phase) (migration / crimp), and leans
  // sideways by fibre_tilt_deg times its own uniform [-1, 1]. A few degrees:
  // a migrating fibre's inclination ~ atan(2 pi r / L) for a radial excursion
  // r ~ 0.05 mm (half a 0.2 mm yarn) over a migration length L ~ 3-5 mm.
  double fibre_tilt_deg = 4.0;           // tilt amplitude, [0, 20] deg
  double fibre_diameter_mm = 0.02;       // width of one fibre across its thread, (0, 0.1] mm
  double fibre_wavelength_mm = 1.1;      // period of the along-fibre inclination, > 0

  // kColorChecker. 16 mm patches on a 20 mm pitch make a 116 x 76 mm grid, a
  // 124 x 84 mm card with the border: the real chart (40 mm pitch) scaled to
  // fit the default 143 x 95 mm field of view with the table visible around
  // it, still ~140 px per patch side at the default quarter resolution.
  double chart_patch_mm = 16.0;          // side of a square patch, > 0
  double chart_pitch_mm = 20.0;          // patch centre spacing, >= chart_patch_mm
  double chart_border_mm = 4.0;          // black surround beyond the outer patches' edges, >= 0
  double chart_thickness_mm = 0.4;       // card thickness above the table, [0, 5]
  double chart_edge_blend_mm = 1.0;      // ramp of the card edge from the table to full thickness, (0, 10]
  Eigen::Vector3d chart_surround_rgb{0.03, 0.03, 0.03};  // the black surround, linear Rec.709, [0, 1]
  double chart_gloss = 0.02;             // specular reflectance added at the mirror direction, [0, 0.2]
  double chart_gloss_width_deg = 12.0;   // half-vector angle where the gloss falls to 1/e, (0, 45]

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

// Height, gradient and albedo at one point; what every query below computes.
struct SurfaceSample {
  double height_mm = 0;                            // z of the surface
  Eigen::Vector2d gradient = Eigen::Vector2d::Zero();  // (dz/dx, dz/dy), dimensionless
  Eigen::Vector3d albedo = Eigen::Vector3d::Zero();    // linear Rec.709 (D65), [0, 1]
  int spectral_patch = -1;   // ColorCheckerClassic() index whose measured spectrum this is; -1 = none
  double gloss = 0;          // specular reflectance added at the mirror direction (SimulatedRig), [0, 0.2]
  // Textile threads (kTextile, on the sample; warp_weight < 0 elsewhere): the
  // share of the warp in the visible surface and both threads' indices.
  double warp_weight = -1;   // [0, 1], -1 = no thread here
  int64_t warp_index = 0, weft_index = 0;
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
  // Linear Rec.709 albedo, each channel in [0, 1].
  Eigen::Vector3d Albedo(double x_mm, double y_mm) const;
  // Width and height of the sample rectangle, mm (kColorChecker: the card).
  Eigen::Vector2d SampleExtentMm() const { return extent_mm_; }
  // Inside the sample rectangle (edges included).
  bool OnSample(double x_mm, double y_mm) const;
  // All of the above at once (one evaluation; what the renderer uses).
  SurfaceSample Sample(double x_mm, double y_mm, bool with_albedo = true) const;

  // The fibre-scale tilt at (x, y) (see fibre_tilt_deg): what the sub-pixel
  // fibres add to the geometric gradient of the SHADING surface, (d/dx,
  // d/dy), dimensionless. Zero for kLambert, off the sample and on the card.
  Eigen::Vector2d FibreTiltGradient(double x_mm, double y_mm) const;
  // The same with the warp's share of the surface given (SurfaceSample::
  // warp_weight; a pixel's, for all of its footprint's sub-samples).
  Eigen::Vector2d FibreTiltGradient(double x_mm, double y_mm, double warp_weight) const;

  // The specular parameters of warp (`warp` true) or weft thread `index` for
  // options().material, with its seeded variation (lambert: cloth_warp/weft).
  ThreadBrdf ThreadBrdfOf(bool warp, int64_t index) const;

  // Upper bound of HeightMm anywhere, mm.
  double MaxHeightMm() const { return max_height_mm_; }

 private:
  struct FoldWave {
    Eigen::Vector2d wave_vector;  // 2 pi * direction / wavelength, rad/mm
    double phase = 0;             // rad
    double weight = 0;            // weights sum to 1
  };

  SurfaceSample Evaluate(double x_mm, double y_mm, bool with_gradient, bool with_albedo) const;
  SurfaceSample EvaluateChart(double x_mm, double y_mm, bool with_gradient, bool with_albedo) const;
  // The folds' height above the base at (x, y), mm; adds its gradient to
  // *gradient when given.
  double FoldHeightMm(double x_mm, double y_mm, Eigen::Vector2d* gradient) const;

  TextileSceneOptions options_;
  std::vector<FoldWave> folds_;
  double max_height_mm_ = 0;
  Eigen::Vector2d extent_mm_ = Eigen::Vector2d::Zero();
};

}  // namespace scanbench
