// Derived maps and export: reads a solve's result folder (normal.exr,
// albedo.exr, confidence/solved mask, report.json) and its session, computes
// the derived maps (flattened normals, height, occlusion, cavity, roughness
// mips, optional tileable crop) and writes them in a preset a material
// pipeline picks up, into a new folder <session>/exports/<run-id>-<preset>[-N]/
// beside earlier exports (never overwriting, staged then renamed).
#pragma once

#include <chrono>
#include <filesystem>
#include <future>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "app/controllers/base_controller.h"
#include "app/io/preview_page.h"
#include "maps/gloss_mips.h"
#include "maps/height_from_normals.h"
#include "maps/normal_flattening.h"
#include "maps/specular_roughness.h"
#include "maps/surface_occlusion.h"
#include "maps/tileable_crop.h"

namespace scanbench {

struct ExportOptions {
  // Generic file formats (exr, png16, tiff16) or an engine's own naming,
  // channel packing and normal convention (unreal, unity-hdrp, gltf; see
  // app/io/engine_presets.h and docs/export.md).
  enum class Preset { kLinearExr, kPng16, kTiff16, kUnreal, kUnityHdrp, kGltf };
  enum class NormalConvention { kOpenGl, kDirectX };  // +Y up (OpenGL) or +Y down (DirectX)
  // Primaries of the linear EXR base colour (issue #12); integer presets are
  // always sRGB (Rec.709 primaries, the sRGB transfer curve).
  enum class BasecolorSpace { kLinearRec709, kAcesCg };
  Preset preset = Preset::kPng16;
  BasecolorSpace basecolor_space = BasecolorSpace::kLinearRec709;
  NormalConvention normal_convention = NormalConvention::kOpenGl;  // generic presets; an engine preset sets its own
  std::string material_name;            // file-name prefix [A-Za-z0-9._-]+; "" = from the sample name
  std::filesystem::path output_root;    // "" = <session>/exports
  double mm_per_pixel = 0;              // physical scale, mm, >= 0; 0 = from the session's rig at the image centre
  bool flatten_normals = true;          // take out low-frequency slope before everything derived
  bool tileable = false;                // also write a seamless tileable crop of every map
  bool preview_page = true;             // also write preview.html, the maps in a browser (app/io/preview_page.h)
  // gltf preset only: also a mesh displaced by the height map, beside the flat tile.
  bool gltf_displaced_mesh = false;
  int gltf_mesh_max_vertices = 65536;   // the displaced grid's vertex budget, [4, 65536] (16-bit indices)
  NormalFlatteningOptions flattening;
  // DCT: the relaxation's least-squares answer (1.5e-4 mm RMS apart on 5.7 mm
  // in the tests) in a fraction of its time. mm_per_pixel is overwritten with
  // the export's scale.
  HeightFromNormalsOptions height{HeightFromNormalsOptions::Method::kDctPoisson};
  // 16 samples per azimuth, not the maps' 32: at the 16 MP pitch (3 mm = 98
  // px) both are 0.0015 from brute-force ray casting (docs/derived-maps.md), and
  // the 16 MP map moves by 9e-5 RMS for about a third less CPU. mm_per_pixel
  // is overwritten with the export's scale.
  AmbientOcclusionOptions occlusion{.max_steps = 16};
  CavityOptions cavity;                 // mm_per_pixel likewise
  GlossMipOptions gloss;
  // With the result's specular.exr (issue #13): its roughness where estimated,
  // feathered into the normal-variance estimate (maps/specular_roughness.h).
  SpecularRoughnessOptions specular_roughness;
  TileableCropOptions tile;  // with tileable only: checked and used only then
  void Check() const;
};
// "exr", "png16", "tiff16", "unreal", "unity-hdrp", "gltf".
const char* ExportPresetName(ExportOptions::Preset preset);
bool IsEnginePreset(ExportOptions::Preset preset);                     // unreal, unity-hdrp, gltf
ExportOptions::Preset ExportPresetFromName(const std::string& name);   // throws std::invalid_argument
const char* NormalConventionName(ExportOptions::NormalConvention convention);            // "opengl", "directx"
const char* BasecolorSpaceName(ExportOptions::BasecolorSpace space);   // "rec709", "acescg"
ExportOptions::BasecolorSpace BasecolorSpaceFromName(const std::string& name);  // throws std::invalid_argument
ExportOptions::NormalConvention NormalConventionFromName(const std::string& name);

// The manifest's schema (material.json): bump the version when its layout changes.
inline constexpr char kMaterialManifestSchema[] = "scanbench.material_export";
inline constexpr int kMaterialManifestSchemaVersion = 1;

struct ExportSummary {
  std::filesystem::path export_dir;
  std::filesystem::path result_dir;                   // what was exported
  std::string material_name;
  std::string preset;                                 // ExportPresetName
  std::string normal_convention;                      // NormalConventionName
  int image_width = 0, image_height = 0;
  double mm_per_pixel = 0;
  std::string mm_per_pixel_source;                    // "options" or "rig at the image centre"
  std::map<std::string, std::string> files;          // map kind -> path relative to export_dir
  double height_min_mm = 0, height_max_mm = 0;        // range of the exported height map
  NormalFlatteningSummary flattening;
  HeightFromNormalsSummary height;
  OcclusionSummary occlusion;
  OcclusionSummary cavity;
  GlossMipSummary gloss;
  // Where mip 0's roughness came from: "normal_variance" (no specular.exr) or
  // "specular_map+normal_variance"; the counts when a specular map was used.
  std::string roughness_source = "normal_variance";
  std::optional<SpecularRoughnessSummary> specular_roughness;
  std::optional<TileableCropSummary> tile;
  std::optional<PreviewPageSummary> preview;          // with options.preview_page
  // Against the session's ground truth (simulated sessions), on solved sample pixels.
  std::optional<double> height_rms_error_mm;         // after removing the best-fit plane
  std::optional<double> flattened_normal_mean_error_deg;
  std::vector<std::string> warnings;
  std::vector<StageTiming> stage_seconds;            // per stage, in order
  double seconds = 0;
  std::string FullReport() const;
};

// What ExportController::Run's steps hand on (defined in export_controller.cc).
struct ExportInputs;       // the result folder, its session and the solved maps
struct ExportMaps;         // the derived maps
struct ExportEarlyNormal;  // the normal file, written while the other maps are derived
struct ExportFile;         // app/io/export_files.h

class ExportController : public BaseController {
 public:
  ExportController(std::filesystem::path result_dir, ExportOptions options);
  // Load, derive, evaluate (simulated sessions), plan the files, write them
  // and the manifest into a staged folder, commit it.
  void Run() override;
  const ExportSummary& summary() const { return summary_; }

 private:
  struct DecodedTruth;     // the session's ground truth files, decoded
  struct HeightReference;  // what the ground-truth evaluation keeps for the height
  struct RoughnessStep;    // the roughness chain, begun beside the evaluation and the height

  // Run's steps, in order.
  void Prepare();
  ExportInputs Load();
  std::future<DecodedTruth> StartDecodingTruth(const ExportInputs& inputs) const;
  ExportMaps Flatten(ExportInputs* inputs);  // releases the solved normals once used
  void StartWritingNormal(const std::filesystem::path& staging, const ExportInputs& inputs, const ExportMaps& maps,
                          ExportEarlyNormal* early);
  HeightReference EvaluateNormals(const ExportInputs& inputs, const ExportMaps& maps, DecodedTruth truth);
  void StartRoughness(ExportInputs* inputs, ExportMaps* maps, RoughnessStep* roughness);
  void DeriveHeight(ExportInputs* inputs, ExportMaps* maps);
  // Occlusion, cavity, the rest of the roughness chain, albedo and
  // confidence's decode and the height's evaluation (with a reference), side by side.
  void DeriveConcurrently(ExportInputs* inputs, ExportMaps* maps, const HeightReference* reference,
                          RoughnessStep* roughness);
  void DeriveTile(const ExportInputs& inputs, ExportMaps* maps);
  std::vector<ExportFile> WriteFiles(const std::filesystem::path& staging, ExportInputs* inputs, ExportMaps* maps,
                                     ExportEarlyNormal* early_normal,
                                     std::future<PreviewPageTextures>* preview_textures);
  void WriteManifestAndSummary(const std::filesystem::path& staging, const ExportInputs& inputs,
                               const std::vector<ExportFile>& files);

  // Inside the steps.
  DecodedTruth DecodeTruth(const ExportInputs& inputs) const;
  void DeriveRoughness(ExportInputs* inputs, ExportMaps* maps, std::vector<StageTiming>* timings,
                       const ProgressCallback& progress);
  void LoadAlbedoAndConfidence(ExportInputs* inputs);
  void EvaluateHeight(const HeightReference& reference, const ExportMaps& maps);

  std::filesystem::path result_dir_;
  ExportOptions options_;
  ExportSummary summary_;
};

}  // namespace scanbench
