#include "app/controllers/export_controller.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <future>
#include <iomanip>
#include <memory>
#include <mutex>
#include <regex>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

#include "app/io/engine_presets.h"
#include "app/io/export_contents.h"
#include "app/io/export_files.h"
#include "app/io/file_util.h"
#include "app/io/gltf_document.h"
#include "app/io/image_io.h"
#include "app/io/materialx_document.h"
#include "app/io/result_maps.h"
#include "app/io/staged_folder.h"
#include "app/session/session.h"
#include "calibration/camera_model.h"
#include "calibration/color_science.h"
#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"
#include "core/summary.h"
#include "pipeline/error_statistics.h"

namespace scanbench {
namespace fs = std::filesystem;

struct ExportInputs {
  fs::path result_dir;            // absolute, <session>/results/<run-id>
  fs::path session_dir;
  Session session;
  fs::path report_path;           // the result's report.json
  nlohmann::json result_report;
  ImageF solved_normals;          // normal.exr, tangent frame; released once flattened (or moved into the maps)
  ImageF albedo;                  // albedo.exr, linear (Rec.709 when colour calibrated); loaded for the tile / files
  ResultAlbedoColor albedo_color;
  ImageF confidence;              // confidence.exr: lights used, condition number, residual; loaded for the files
  ImageU8 valid;                  // solved_mask.png: 1 = solved
  ImageF specular_alpha;          // specular.exr's roughness_alpha (GGX, 0 = not estimated); empty without the file
};

struct ExportMaps {
  ImageF normals;                 // flattened (or as solved), tangent frame
  ImageF height_mm;
  ImageF occlusion;
  ImageF cavity;
  std::vector<GlossMipLevel> mips;
  std::vector<ImageF> tiles;      // empty, or the tiles of TileInputs' maps in order
};

struct ExportController::DecodedTruth {
  ImageF normals;     // the true normals (tangent frame)
  ImageU8 on_sample;  // 1 on the sample
  ImageF height_mm;   // the true height, read only when it is the reference (unflattened)
};

struct ExportController::HeightReference {
  ImageF height_mm;  // the true height, or the true normals flattened and integrated like the export's
  ImageU8 evaluated;  // 1 on the sample's solved pixels
};

namespace {

constexpr char kWhere[] = "ExportOptions";

// Linear Rec.709 -> linear ACEScg, per pixel.
ImageF ToAcescg(const ImageF& linear_rec709) {
  const Eigen::Matrix3f m = AcescgFromLinearRec709().cast<float>();
  ImageF out = linear_rec709;
  for (size_t i = 0; i < out.num_pixels(); ++i) {
    Eigen::Map<Eigen::Vector3f> rgb(out.data() + 3 * i);
    rgb = m * Eigen::Vector3f(rgb);
  }
  return out;
}

std::runtime_error FileError(const fs::path& path, const std::string& problem) {
  return std::runtime_error(path.string() + ": " + problem);
}

std::string MaterialNameFromSample(const std::string& sample_name) {
  std::string name;
  for (char c : sample_name) {
    const bool allowed = std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
    if (allowed) {
      name += c;
    } else if (!name.empty() && name.back() != '_') {
      name += '_';
    }
  }
  while (!name.empty() && (name.back() == '_' || name.back() == '.')) name.pop_back();
  while (!name.empty() && name.front() == '.') name.erase(name.begin());
  return name.empty() ? "material" : name;
}

// The export's scale into the summary: the options' when given, else the
// session rig's pixel footprint at the image centre; a warning when a
// simulated session's rig says otherwise by more than 1 %.
void ResolveScale(const Session& session, const fs::path& session_dir, double mm_per_pixel_option,
                  ExportSummary* summary) {
  if (mm_per_pixel_option > 0) {
    summary->mm_per_pixel = mm_per_pixel_option;
    summary->mm_per_pixel_source = "options";
  } else {
    summary->mm_per_pixel = TablePixelFootprintMm(session.rig.camera);
    summary->mm_per_pixel_source = "session rig at the image centre";
    if (!std::isfinite(summary->mm_per_pixel) || !(summary->mm_per_pixel > 0)) {
      throw FileError(session_dir / "session.json",
                      "rig.camera gives a pixel footprint of " + std::to_string(summary->mm_per_pixel) +
                          " mm at the image centre; give --mm-per-pixel");
    }
  }
  if (session.ground_truth && std::abs(session.ground_truth->mm_per_pixel / summary->mm_per_pixel - 1) > 0.01) {
    std::ostringstream warning;
    warning << "scale " << summary->mm_per_pixel << " mm/px differs from the simulated rig's "
            << session.ground_truth->mm_per_pixel << " mm/px by more than 1 %";
    summary->warnings.push_back(warning.str());
  }
}

// The height options at the export's scale.
HeightFromNormalsOptions ScaledHeightOptions(const ExportOptions& options, double mm_per_pixel) {
  HeightFromNormalsOptions height = options.height;
  height.mm_per_pixel = mm_per_pixel;
  return height;
}

// The normals in DirectX convention, Y flipped; OpenGL is the solver's
// tangent frame (+Y up) and is written as it is.
ImageF DirectXNormals(const ImageF& normal_in_tangent) {
  ImageF converted = normal_in_tangent;
  for (size_t i = 0; i < converted.num_pixels(); ++i) converted.data()[3 * i + 1] *= -1.0f;
  return converted;
}

// The given result folder, absolute, without a trailing separator ("results/<run-id>/").
fs::path NormalisedResultDir(const fs::path& given) {
  fs::path result_dir = fs::absolute(given).lexically_normal();
  if (!result_dir.has_filename()) result_dir = result_dir.parent_path();
  return result_dir;
}

void CheckIsResultFolder(const fs::path& result_dir) {
  std::error_code error;
  if (!fs::is_directory(result_dir, error)) throw FileError(result_dir, "is not a result folder (does not exist)");
  if (result_dir.parent_path().filename() != "results") {
    throw FileError(result_dir, "is not a result folder: results live in <session>/results/<run-id>/");
  }
}

nlohmann::json ReadJsonFile(const fs::path& path) {
  try {
    return nlohmann::json::parse(ReadFileBytes(path));
  } catch (const nlohmann::json::exception& parse_error) {
    throw FileError(path, std::string("is not valid JSON (") + parse_error.what() + ")");
  }
}

std::string TangentFrameText(ExportOptions::NormalConvention convention) {
  return convention == ExportOptions::NormalConvention::kDirectX
             ? "unit normal, tangent frame x right, y down (DirectX), z out of the sample"
             : "unit normal, tangent frame x right, y up (OpenGL), z out of the sample";
}

// "roughness_mip03": the kind (and file name part) of a mip level, two digits so
// that the files sort in level order (mip10 after mip09; 16 MP has 13 levels).
std::string MipKind(const std::string& map, size_t level) {
  return map + "_mip" + (level < 10 ? "0" : "") + std::to_string(level);
}

// The maps the tileable crop cuts, in the order of ExportMaps::tiles.
std::vector<TileableMapInput> TileInputs(const ExportInputs& inputs, const ExportMaps& maps) {
  return {{&inputs.albedo, TileMapKind::kLinear},   {&maps.normals, TileMapKind::kNormal},
          {&maps.height_mm, TileMapKind::kLinear},  {&maps.occlusion, TileMapKind::kLinear},
          {&maps.cavity, TileMapKind::kLinear},     {&maps.mips.front().roughness, TileMapKind::kLinear}};
}

nlohmann::json OptionsJson(const ExportOptions& options) {
  const auto& h = options.height;
  const auto& a = options.occlusion;
  const auto& c = options.cavity;
  const auto& g = options.gloss;
  const auto& t = options.tile;
  return {{"preset", ExportPresetName(options.preset)},
          {"normal_convention", NormalConventionName(options.normal_convention)},
          {"basecolor_space", BasecolorSpaceName(options.basecolor_space)},
          {"material_name", options.material_name},
          {"output_root", options.output_root.string()},
          {"mm_per_pixel", options.mm_per_pixel},
          {"flatten_normals", options.flatten_normals},
          {"tileable", options.tileable},
          {"preview_page", options.preview_page},
          {"gltf_displaced_mesh", options.gltf_displaced_mesh},
          {"gltf_mesh_max_vertices", options.gltf_mesh_max_vertices},
          {"flattening",
           {{"low_pass_sigma_px", options.flattening.low_pass_sigma_px}, {"max_slope", options.flattening.max_slope}}},
          {"height",
           {{"method", HeightMethodName(h.method)},
            {"max_sweeps_per_level", h.max_sweeps_per_level},
            {"tolerance", h.tolerance},
            {"coarsest_level_size", h.coarsest_level_size},
            {"max_slope", h.max_slope}}},
          {"occlusion",
           {{"radius_mm", a.radius_mm}, {"num_directions", a.num_directions}, {"max_steps", a.max_steps}}},
          {"cavity",
           {{"radius_mm", c.radius_mm},
            {"depth_scale_mm", c.depth_scale_mm},
            {"min_coarse_sigma_px", c.min_coarse_sigma_px}}},
          {"gloss",
           {{"model", GlossModelName(g.model)}, {"base_roughness", g.base_roughness}, {"max_levels", g.max_levels}}},
          {"tile",
           {{"tile_width", t.tile_width},
            {"tile_height", t.tile_height},
            {"blend_width_px", t.blend_width_px},
            {"search_position", t.search_position}}}};
}

nlohmann::json OcclusionJson(const OcclusionSummary& summary) {
  return {{"termination", TerminationName(summary.termination)},
          {"message", summary.message},
          {"mean", summary.mean},
          {"min", summary.min},
          {"max", summary.max},
          {"radius_px", summary.radius_px},
          {"seconds", summary.seconds}};
}

nlohmann::json SummariesJson(const ExportSummary& summary) {
  const auto& f = summary.flattening;
  const auto& h = summary.height;
  const auto& g = summary.gloss;
  nlohmann::json json = {
      {"flattening",
       {{"termination", TerminationName(f.termination)},
        {"message", f.message},
        {"valid_pixels", f.valid_pixels},
        {"mean_removed_tilt_deg", f.mean_removed_tilt_deg},
        {"max_removed_tilt_deg", f.max_removed_tilt_deg},
        {"seconds", f.seconds}}},
      {"height",
       {{"termination", TerminationName(h.termination)},
        {"message", h.message},
        {"method", h.method},
        {"levels", h.levels},
        {"total_sweeps", h.total_sweeps},
        {"converged", h.converged},
        {"rms_slope_residual", h.rms_slope_residual},
        {"min_mm", summary.height_min_mm},
        {"max_mm", summary.height_max_mm},
        {"seconds", h.seconds}}},
      {"occlusion", OcclusionJson(summary.occlusion)},
      {"cavity", OcclusionJson(summary.cavity)},
      {"gloss",
       {{"termination", TerminationName(g.termination)},
        {"message", g.message},
        {"model", g.model},
        {"levels", g.mean_roughness.size()},
        {"mean_roughness", g.mean_roughness},
        {"seconds", g.seconds}}}};
  if (summary.tile) {
    const TileableCropSummary& t = *summary.tile;
    json["tile"] = {{"termination", TerminationName(t.termination)},
                    {"message", t.message},
                    {"x0", t.x0},
                    {"y0", t.y0},
                    {"width", t.tile_width},
                    {"height", t.tile_height},
                    {"seam_cost", t.seam_cost},
                    {"seconds", t.seconds}};
  }
  return json;
}

// --- Planning the files -----------------------------------------------------

// The files of one export, each with its image, encoding and metadata, in the
// order they are listed.
class FilePlanner {
 public:
  FilePlanner(const ExportOptions& options, const ExportSummary& summary, const std::string& source_result)
      : options_(options),
        summary_(summary),
        exr_(options.preset == ExportOptions::Preset::kLinearExr),
        format_(exr_ ? "exr" : options.preset == ExportOptions::Preset::kTiff16 ? "tiff" : "png"),
        extension_(exr_ ? ".exr" : format_ == "png" ? ".png" : ".tif"),
        source_result_(source_result) {}

  // A float map in the preset's format (EXR float, else 16-bit integers),
  // borrowed: `image` must outlive the writing of the files.
  ExportFile* AddMap(const std::string& kind, const ImageF& image, const std::string& color_space,
                     const IntegerEncoding& integer, const std::string& description, double pixel_mm,
                     bool force_exr = false) {
    // The aliasing constructor with an empty owner: a pointer that frees nothing.
    return AddMap(kind, std::shared_ptr<const ImageF>(std::shared_ptr<void>(), &image), color_space, integer,
                  description, pixel_mm, force_exr);
  }
  // The same for an image made for this file only (a packed or converted map).
  ExportFile* AddMap(const std::string& kind, ImageF&& image, const std::string& color_space,
                     const IntegerEncoding& integer, const std::string& description, double pixel_mm,
                     bool force_exr = false) {
    return AddMap(kind, std::make_shared<const ImageF>(std::move(image)), color_space, integer, description,
                  pixel_mm, force_exr);
  }
  ExportFile* AddMap(const std::string& kind, std::shared_ptr<const ImageF> image_ptr, const std::string& color_space,
                     const IntegerEncoding& integer, const std::string& description, double pixel_mm,
                     bool force_exr) {
    const ImageF& image = *image_ptr;
    ExportFile file;
    file.kind = kind;
    const bool as_exr = exr_ || force_exr;
    file.format = as_exr ? "exr" : format_;
    file.relative_path = RelativePath(kind, as_exr ? ".exr" : extension_);
    file.is_float = as_exr;
    file.bits_per_sample = as_exr ? 32 : 16;
    file.width = image.width();
    file.height = image.height();
    file.channels = image.channels();
    file.color_space = color_space;
    file.encoding = as_exr ? "float, value as is" : integer.text;
    file.mm_per_pixel = pixel_mm;
    file.integer = integer;
    file.float_image = std::move(image_ptr);
    file.metadata = Metadata(file, description);
    return &files_.emplace_back(std::move(file));
  }

  // The albedo as base colour: linear EXR in Rec.709 or ACEScg primaries (with
  // their chromaticities), or 16-bit through the sRGB transfer curve. An albedo
  // that was not colour calibrated says so and carries no chromaticities.
  void AddBasecolor(const std::string& kind, const ImageF& albedo_linear_rec709, const ResultAlbedoColor& color,
                    double pixel_mm) {
    const bool calibrated = color.color_space == "linear_rec709";
    const bool acescg = calibrated && options_.basecolor_space == ExportOptions::BasecolorSpace::kAcesCg;
    // What the file holds is the preset table's (app/io/export_contents.h),
    // which the dialog and the help show: its transfer curve decides the integers.
    const ExportPresetContents& contents = ExportPresetContentsOf(ExportPresetName(options_.preset));
    if (exr_ && contents.basecolor_srgb) {
      throw std::logic_error(std::string("export preset ") + contents.name +
                             ": app/io/export_contents.cc gives an sRGB base colour, but EXR stores floats as they are");
    }
    const IntegerEncoding srgb = contents.basecolor_srgb
                                     ? IntegerEncoding{1, 0, "uint16 = srgb_transfer(value) * 65535, value in [0, 1]", true}
                                     : IntegerEncoding{1, 0, "uint16 = value * 65535, value in [0, 1]", false};
    const std::string space = !calibrated ? "white-balanced camera RGB (not colour calibrated)"
                              : acescg    ? "linear ACEScg (AP1 primaries, ACES white)"
                                          : "linear Rec.709 primaries, D65 white";
    const std::string description = "diffuse albedo, " + space + ", " + color.scale + " reflectance";
    const std::string file_space = BasecolorColorSpace(contents);
    ExportFile* file = acescg ? AddMap(kind, ToAcescg(albedo_linear_rec709), file_space, srgb, description, pixel_mm)
                              : AddMap(kind, albedo_linear_rec709, file_space, srgb, description, pixel_mm);
    file->metadata.attributes["scanbench:albedo_color_space"] = acescg ? "acescg" : color.color_space;
    file->metadata.attributes["scanbench:albedo_scale"] = color.scale;
    if (calibrated) {
      const Chromaticities c = acescg ? AcescgChromaticities() : Rec709Chromaticities();
      file->metadata.chromaticities =
          ImageChromaticities{c.red_x, c.red_y, c.green_x, c.green_y, c.blue_x, c.blue_y, c.white_x, c.white_y};
    }
  }

  // Unit normals in the export's convention.
  void AddNormal(const std::string& kind, const ImageF& normal_in_tangent, double pixel_mm) {
    static const IntegerEncoding kNormalEncoding{0.5, 0.5, "uint16 = (n + 1) / 2 * 65535 per component"};
    const bool directx = options_.normal_convention == ExportOptions::NormalConvention::kDirectX;
    const std::string frame = TangentFrameText(options_.normal_convention);
    ExportFile* file = directx ? AddMap(kind, DirectXNormals(normal_in_tangent), "Raw", kNormalEncoding, frame, pixel_mm)
                               : AddMap(kind, normal_in_tangent, "Raw", kNormalEncoding, frame, pixel_mm);
    file->metadata.attributes["scanbench:normal_convention"] = NormalConventionName(options_.normal_convention);
  }

  // Heights in mm as float EXR, and for integer presets also normalised to
  // [0, 1] over the exported height range.
  void AddHeight(const std::string& kind, const ImageF& heights, double pixel_mm) {
    AddMap(kind, heights, "Raw", {}, "height above the mean of the solved pixels, mm", pixel_mm, true);
    if (exr_) return;
    const double low = summary_.height_min_mm, range = summary_.height_max_mm - summary_.height_min_mm;
    const IntegerEncoding encoding{range > 0 ? 1.0 / range : 0.0, range > 0 ? -low / range : 0.0,
                                   "uint16 = (height_mm - height_min_mm) / (height_max_mm - height_min_mm) * 65535"};
    ExportFile* file = AddMap(kind + "_normalized", heights, "Raw", encoding,
                              "height normalised to [0, 1] over its range (see height_min_mm, height_max_mm)",
                              pixel_mm);
    std::ostringstream low_text, high_text;
    low_text << std::setprecision(9) << summary_.height_min_mm;
    high_text << std::setprecision(9) << summary_.height_max_mm;
    file->metadata.attributes["scanbench:height_min_mm"] = low_text.str();
    file->metadata.attributes["scanbench:height_max_mm"] = high_text.str();
  }

  // An 8-bit PNG stored as it is (mask).
  ExportFile* AddU8(const std::string& kind, ImageU8 image, const std::string& color_space,
                    const std::string& encoding, const std::string& description) {
    ExportFile file = Png8(kind, image, color_space, encoding);
    file.u8_image = std::make_shared<const ImageU8>(std::move(image));
    file.metadata = Metadata(file, description);
    return &files_.emplace_back(std::move(file));
  }

  // Linear RGB as 8-bit sRGB PNG (uint8 = lround(srgb_transfer(value) * 255)),
  // borrowed: `linear_rgb` must outlive the writing of the files.
  ExportFile* AddSrgb8(const std::string& kind, const ImageF& linear_rgb, const std::string& encoding,
                       const std::string& description) {
    ExportFile file = Png8(kind, linear_rgb, "sRGB", encoding);
    file.float_image = std::shared_ptr<const ImageF>(std::shared_ptr<void>(), &linear_rgb);
    file.srgb8 = true;
    file.metadata = Metadata(file, description);
    return &files_.emplace_back(std::move(file));
  }

  // A document stored as it is, at <material>/<file_name>.
  void AddDocument(const std::string& kind, const std::string& file_name, const std::string& format,
                   std::string content, const std::string& description) {
    ExportFile file;
    file.kind = kind;
    file.format = format;
    file.relative_path = InMaterialFolder(file_name);
    file.encoding = description;
    file.mm_per_pixel = summary_.mm_per_pixel;
    file.document = std::make_shared<const std::string>(std::move(content));
    files_.push_back(std::move(file));
  }

  // The file planned as `kind` (which must exist), e.g. to reference it from a document.
  const ExportFile& Find(const std::string& kind) const {
    const auto found = std::find_if(files_.begin(), files_.end(), [&](const ExportFile& f) { return f.kind == kind; });
    if (found == files_.end()) throw std::logic_error("export plan has no file '" + kind + "'");
    return *found;
  }
  ExportFile& Find(const std::string& kind) { return const_cast<ExportFile&>(std::as_const(*this).Find(kind)); }
  std::string InMaterialFolder(const std::string& file_name) const {
    return summary_.material_name + "/" + file_name;
  }

  std::vector<ExportFile> Take() { return std::move(files_); }

 private:
  std::string RelativePath(const std::string& kind, const std::string& extension) const {
    const std::string& material = summary_.material_name;
    return material + "/" + material + "_" + kind + extension;
  }
  // An 8-bit PNG's entry of `image`'s layout; its pixels and metadata are the caller's.
  template <typename T>
  ExportFile Png8(const std::string& kind, const Image<T>& image, const std::string& color_space,
                  const std::string& encoding) const {
    ExportFile file;
    file.kind = kind;
    file.format = "png";
    file.relative_path = RelativePath(kind, ".png");
    file.bits_per_sample = 8;
    file.width = image.width();
    file.height = image.height();
    file.channels = image.channels();
    file.color_space = color_space;
    file.encoding = encoding;
    file.mm_per_pixel = summary_.mm_per_pixel;
    return file;
  }
  ImageMetadata Metadata(const ExportFile& file, const std::string& description) const {
    ImageMetadata metadata;
    metadata.mm_per_pixel = file.mm_per_pixel;
    metadata.description = "scanbench " + summary_.material_name + " " + file.kind + ": " + description;
    metadata.color_space = file.color_space;
    metadata.attributes["scanbench:map"] = file.kind;
    metadata.attributes["scanbench:encoding"] = file.encoding;
    metadata.attributes["scanbench:source_result"] = source_result_;
    return metadata;
  }

  const ExportOptions& options_;
  const ExportSummary& summary_;
  const bool exr_;
  const std::string format_, extension_, source_result_;
  std::vector<ExportFile> files_;
};

const IntegerEncoding kUnitInterval{1, 0, "uint16 = value * 65535, value in [0, 1]"};

std::optional<EngineTarget> EngineTargetOf(ExportOptions::Preset preset) {
  switch (preset) {
    case ExportOptions::Preset::kUnreal: return EngineTarget::kUnreal;
    case ExportOptions::Preset::kUnityHdrp: return EngineTarget::kUnityHdrp;
    case ExportOptions::Preset::kGltf: return EngineTarget::kGltf;
    default: return std::nullopt;
  }
}

// The generic presets' maps: base colour, normals, height, occlusion,
// cavity, the roughness and normal mip chains and the tiles.
void PlanGenericMaps(const ExportSummary& summary, const ExportInputs& inputs, ExportMaps& maps,
                     FilePlanner& plan) {
  const IntegerEncoding& unit_interval = kUnitInterval;
  const double mm = summary.mm_per_pixel;
  plan.AddBasecolor("basecolor", inputs.albedo, inputs.albedo_color, mm);
  plan.AddNormal("normal", maps.normals, mm);
  plan.AddHeight("height", maps.height_mm, mm);
  plan.AddMap("ao", maps.occlusion, "Raw", unit_interval, "ambient occlusion, cosine-weighted visibility, 1 = open",
              mm);
  // The cavity's one user is its file: moved in, so it is freed once written.
  plan.AddMap("cavity", std::move(maps.cavity), "Raw", unit_interval,
              "cavity, 1 = at or above the neighbourhood, 0 = deep", mm);
  for (size_t k = 0; k < maps.mips.size(); ++k) {
    const double pixel_mm = mm * std::ldexp(1.0, static_cast<int>(k));
    plan.AddMap(MipKind("roughness", k), maps.mips[k].roughness, "Raw", unit_interval,
                "GGX alpha (" + summary.gloss.model + " mip chain; normal variance below this level folded in" +
                    (summary.specular_roughness ? "; mip 0 from specular.exr where estimated)" : ")"),
                pixel_mm);
    if (k > 0) plan.AddNormal(MipKind("normal", k), maps.mips[k].normal_in_tangent, pixel_mm);
  }
  if (!maps.tiles.empty()) {
    plan.AddBasecolor("tile_basecolor", maps.tiles[0], inputs.albedo_color, mm);
    plan.AddNormal("tile_normal", maps.tiles[1], mm);
    plan.AddHeight("tile_height", maps.tiles[2], mm);
    plan.AddMap("tile_ao", maps.tiles[3], "Raw", unit_interval, "tileable crop of ao", mm);
    plan.AddMap("tile_cavity", maps.tiles[4], "Raw", unit_interval, "tileable crop of cavity", mm);
    plan.AddMap("tile_roughness", maps.tiles[5], "Raw", unit_interval, "tileable crop of roughness_mip00", mm);
  }
}

// What the engine presets pack, for one set of maps (the full image or the tile).
struct EngineMapSet {
  const ImageF& albedo;
  const ImageF& normals;
  const ImageF& height_mm;
  const ImageF& occlusion;
  const ImageF& ggx_alpha;
};

// One engine's textures under its own names: 8-bit sRGB base colour, 16-bit
// normals in its convention, its packed linear texture with perceptual
// roughness, the float height (mm) and the 16-bit normalised height. Kinds
// start with `kind_prefix` ("" or "tile_").
void PlanEngineMaps(EngineTarget target, const std::string& kind_prefix, const std::string& stem,
                    const EngineMapSet& set, const ExportSummary& summary, const ResultAlbedoColor& color,
                    FilePlanner& plan) {
  const double mm = summary.mm_per_pixel;
  const EngineTextureNames names = EngineTextureNamesOf(target, stem);
  ExportFile* basecolor = plan.AddSrgb8(kind_prefix + "basecolor", set.albedo,
                                     "uint8 = srgb_transfer(value) * 255, value in [0, 1]",
                                     "diffuse albedo (" + color.color_space + ", " + color.scale +
                                         " reflectance), sRGB transfer curve");
  basecolor->relative_path = plan.InMaterialFolder(names.basecolor);
  basecolor->metadata.attributes["scanbench:albedo_color_space"] = color.color_space;
  basecolor->metadata.attributes["scanbench:albedo_scale"] = color.scale;

  plan.AddNormal(kind_prefix + "normal", set.normals, mm);
  plan.Find(kind_prefix + "normal").relative_path = plan.InMaterialFolder(names.normal);

  const bool hdrp = target == EngineTarget::kUnityHdrp;
  const std::string packed_kind = kind_prefix + (hdrp                              ? "mask_map"
                                                 : target == EngineTarget::kUnreal ? "orm"
                                                                                   : "occlusion_roughness_metallic");
  const std::string layout = hdrp ? "R metallic = 0, G ambient occlusion, B detail mask = 1, A smoothness = "
                                    "1 - perceptual roughness"
                                  : "R ambient occlusion, G perceptual roughness, B metallic = 0";
  ExportFile* packed = plan.AddMap(packed_kind,
                                   hdrp ? PackHdrpMaskMap(set.occlusion, set.ggx_alpha)
                                        : PackOcclusionRoughnessMetallic(set.occlusion, set.ggx_alpha),
                                   "Raw", kUnitInterval,
                                   layout + " (perceptual roughness = sqrt(GGX alpha)), linear", mm);
  packed->relative_path = plan.InMaterialFolder(names.packed);
  packed->metadata.attributes["scanbench:channels"] = layout;

  plan.AddHeight(kind_prefix + "height", set.height_mm, mm);
  if (!names.height_normalized.empty()) {
    plan.Find(kind_prefix + "height_normalized").relative_path =
        plan.InMaterialFolder(names.height_normalized);
  }
}

std::string FileName(const ExportFile& file) { return fs::path(file.relative_path).filename().string(); }

// The .mtlx of every export, beside the maps it reads.
std::string MaterialXOf(const ExportOptions& options, const ExportSummary& summary, const ExportInputs& inputs,
                        const FilePlanner& plan) {
  MaterialXMaterialOptions mtlx;
  mtlx.name = summary.material_name;
  mtlx.basecolor_file = FileName(plan.Find("basecolor"));
  const bool calibrated = inputs.albedo_color.color_space == "linear_rec709";
  mtlx.basecolor_colorspace = options.preset != ExportOptions::Preset::kLinearExr ? "srgb_texture"
                              : calibrated && options.basecolor_space == ExportOptions::BasecolorSpace::kAcesCg
                                  ? "acescg"
                                  : "lin_rec709";
  mtlx.normal_file = FileName(plan.Find("normal"));
  mtlx.normal_y_down = options.normal_convention == ExportOptions::NormalConvention::kDirectX;
  mtlx.height_file = FileName(plan.Find("height"));
  mtlx.height_scale = 0.001;  // mm -> metres
  const std::optional<EngineTarget> engine = EngineTargetOf(options.preset);
  if (!engine) {
    mtlx.roughness_file = FileName(plan.Find(MipKind("roughness", 0)));
    mtlx.roughness = MaterialXMaterialOptions::Roughness::kGgxAlpha;
  } else if (*engine == EngineTarget::kUnityHdrp) {
    mtlx.roughness_file = FileName(plan.Find("mask_map"));
    mtlx.roughness_channels = 4;
    mtlx.roughness_channel = 3;
    mtlx.roughness = MaterialXMaterialOptions::Roughness::kSmoothness;
  } else {
    mtlx.roughness_file = FileName(plan.Find(*engine == EngineTarget::kUnreal ? "orm" : "occlusion_roughness_metallic"));
    mtlx.roughness_channels = 3;
    mtlx.roughness_channel = 1;
    mtlx.roughness = MaterialXMaterialOptions::Roughness::kPerceptual;
  }
  return MaterialXDocument(mtlx);
}

// Every file of the export: the maps (generic or in an engine's layout), the
// solver's confidence, the mask, the sRGB preview (generic presets), the
// MaterialX document and, for gltf, the .gltf and its .bin.
// The maps whose only user is their file (the confidence, the generic
// presets' cavity) are moved into it, so that they are freed once written.
std::vector<ExportFile> PlanFiles(const ExportOptions& options, const ExportSummary& summary,
                                  ExportInputs& inputs, ExportMaps& maps) {
  const double mm = summary.mm_per_pixel;
  FilePlanner plan(options, summary, inputs.result_dir.filename().string());
  const std::optional<EngineTarget> engine = EngineTargetOf(options.preset);
  if (engine) {
    PlanEngineMaps(*engine, "", summary.material_name,
                   {inputs.albedo, maps.normals, maps.height_mm, maps.occlusion, maps.mips.front().roughness},
                   summary, inputs.albedo_color, plan);
    if (!maps.tiles.empty()) {
      PlanEngineMaps(*engine, "tile_", summary.material_name + "_Tile",
                     {maps.tiles[0], maps.tiles[1], maps.tiles[2], maps.tiles[3], maps.tiles[5]}, summary,
                     inputs.albedo_color, plan);
    }
  } else {
    PlanGenericMaps(summary, inputs, maps, plan);
  }
  ExportFile* confidence =
      plan.AddMap("confidence", std::move(inputs.confidence), "Raw", {},
                  "solver confidence: lights used, condition number, RMS residual / albedo", mm, true);
  confidence->channel_names = ConfidenceChannelNames();
  ImageU8 mask(inputs.valid.width(), inputs.valid.height(), 1);
  for (size_t i = 0; i < mask.num_pixels(); ++i) mask.data()[i] = inputs.valid.data()[i] ? 255 : 0;
  plan.AddU8("mask", std::move(mask), "Raw", "uint8 255 = solved, 0 = not solved (normal (0, 0, 1), albedo 0)",
             "pixels the solver solved");
  if (!engine) {
    plan.AddSrgb8("basecolor_srgb_preview", inputs.albedo, "uint8 sRGB transfer curve",
                  "8-bit sRGB preview of the basecolor (" + inputs.albedo_color.color_space + ")");
  }
  const std::string& material = summary.material_name;
  plan.AddDocument("materialx", material + ".mtlx", "mtlx", MaterialXOf(options, summary, inputs, plan),
                   "MaterialX 1.38: standard_surface + displacement reading this folder's maps");
  if (options.preset == ExportOptions::Preset::kGltf) {
    GltfTileOptions tile;
    tile.name = material;
    tile.width_m = summary.image_width * mm / 1000;
    tile.height_m = summary.image_height * mm / 1000;
    tile.basecolor_uri = FileName(plan.Find("basecolor"));
    tile.normal_uri = FileName(plan.Find("normal"));
    tile.occlusion_roughness_metallic_uri = FileName(plan.Find("occlusion_roughness_metallic"));
    tile.buffer_uri = material + ".bin";
    tile.generator = "scanbench " SCANBENCH_VERSION;
    tile.displaced_max_vertices = options.gltf_mesh_max_vertices;
    tile.height_unit_m = 0.001;  // the height map is in mm
    GltfTileFiles gltf = BuildGltfTile(tile, options.gltf_displaced_mesh ? &maps.height_mm : nullptr);
    const std::string displaced = options.gltf_displaced_mesh ? " and a mesh displaced by the height map" : "";
    plan.AddDocument("gltf", material + ".gltf", "gltf", std::move(gltf.json),
                     "glTF 2.0: a flat tile of the sample's size in metres" + displaced +
                         ", with its metallicRoughness material");
    plan.AddDocument("gltf_buffer", tile.buffer_uri, "bin",
                     std::string(gltf.buffer.begin(), gltf.buffer.end()),
                     "glTF buffer: positions, normals, tangents, UVs (float32), indices (uint16)");
  }
  return plan.Take();
}

// --- Writing -----------------------------------------------------------------

// The generic presets' normal file (OpenGL: it borrows the map, no copy), as
// PlanFiles plans it: the normals are final once flattened, so the export
// writes this file while the evaluation and the height run (they leave a core
// mostly idle). Engine presets and DirectX normals: none (written with the rest).
std::optional<ExportFile> EarlyNormalFile(const ExportOptions& options, const ExportSummary& summary,
                                          const ExportInputs& inputs, const ExportMaps& maps) {
  if (IsEnginePreset(options.preset) || options.normal_convention != ExportOptions::NormalConvention::kOpenGl) {
    return std::nullopt;
  }
  FilePlanner plan(options, summary, inputs.result_dir.filename().string());
  plan.AddNormal("normal", maps.normals, summary.mm_per_pixel);
  return std::move(plan.Take().front());
}


// Compression dominates; the files are independent, so they are written
// concurrently. `report` gets the fraction of files done (up to 0.9). The
// first failure is rethrown once every write has ended.
void WriteFilesConcurrently(const fs::path& staging, std::vector<ExportFile>& files,
                            const std::function<void(double)>& report, const std::string& written_kind = "") {
  // On the shared pool, one file per thread at a time: each integer file
  // holds its quantised copy while it encodes, so a thread per file would
  // hold them all at once.
  // Largest first, so that no thread is left with a large file while the others are done.
  // `written_kind`'s file is already written (EarlyNormalFile).
  std::vector<int> order;
  for (int i = 0; i < static_cast<int>(files.size()); ++i) {
    if (files[i].kind != written_kind) order.push_back(i);
  }
  const int count = static_cast<int>(order.size());
  auto samples = [&files](int i) {
    const ExportFile& f = files[i];
    return static_cast<double>(f.width) * f.height * f.channels * (f.is_float ? 2 : 1);
  };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return samples(a) > samples(b); });
  ParallelFor(
      count, ResolveThreadCount(0), 1,
      [&](int first, int last, int) {
        for (int i = first; i < last; ++i) {
          ExportFile& file = files[order[i]];
          WriteExportFile(staging / file.relative_path, file);
          file.float_image.reset(), file.u8_image.reset();  // frees what the file owns (borrowed maps stay)
        }
      },
      [&](int done) {
        report(0.9 * done / count);
        return true;
      });
}

// Hashes and sizes of the written files, for the manifest; lists them in the summary.
void RecordWrittenFiles(const fs::path& staging, std::vector<ExportFile>* files, ExportSummary* summary) {
  ParallelFor(static_cast<int>(files->size()), ResolveThreadCount(0), 1, [&](int first, int last, int) {
    for (int i = first; i < last; ++i) {
      ExportFile& file = (*files)[i];
      const fs::path path = staging / file.relative_path;
      file.sha256 = Sha256HexOfFile(path);
      file.bytes = fs::file_size(path);
    }
  });
  for (const ExportFile& file : *files) summary->files[file.kind] = file.relative_path;
}

// preview.html beside material.json: the base colour, flattened normals
// (tangent frame, whatever the files' convention), mip 0's roughness, the
// occlusion and height of the sample (the tileable crop when there is one)
// on a tile and a dome, listing the files written.
// Its textures need only the maps, so they are made while the files are
// written (PreviewTexturesOf); the page itself needs the files' sizes.
PreviewPageOptions PreviewOptionsOf(const ExportInputs& inputs, const ExportSummary& summary) {
  PreviewPageOptions options;
  options.title = summary.material_name;
  options.basecolor_note = inputs.albedo_color.color_space == "linear_rec709"
                               ? "linear Rec.709, " + inputs.albedo_color.scale
                               : "white-balanced camera RGB (not colour calibrated)";
  return options;
}

constexpr char kPreviewPath[] = "preview.html";

PreviewPageTextures PreviewTexturesOf(const fs::path& staging, const ExportInputs& inputs, const ExportMaps& maps,
                                      const ExportSummary& summary, const ProgressCallback& progress) {
  PreviewPageMapViews views;
  views.basecolor_linear_rec709 = &inputs.albedo;
  views.normal_in_tangent = &maps.normals;
  if (!maps.mips.empty()) views.roughness_alpha = &maps.mips[0].roughness;
  views.occlusion = &maps.occlusion;
  views.height_mm = &maps.height_mm;
  views.valid = &inputs.valid;
  if (!maps.tiles.empty()) {
    // The tileable crop is the sample the page shows (TileMapsOf's order: albedo, normals, height, occlusion,
    // cavity, roughness).
    views.tile_basecolor_linear_rec709 = &maps.tiles[0];
    views.tile_normal_in_tangent = &maps.tiles[1];
    views.tile_occlusion = &maps.tiles[3];
    views.tile_roughness_alpha = &maps.tiles[5];
  }
  return MakePreviewTextures(PreviewOptionsOf(inputs, summary), views, summary.mm_per_pixel, staging / kPreviewPath,
                             progress);
}

void WritePreview(const fs::path& staging, const ExportInputs& inputs, const PreviewPageTextures& textures,
                  const ProgressCallback& progress, std::vector<ExportFile>* files, ExportSummary* summary) {
  if (textures.summary.IsCancelled()) throw Cancelled("preview page");
  std::vector<PreviewPageFile> listed;
  for (const ExportFile& file : *files) listed.push_back({file.relative_path, file.bytes});
  ExportFile page;
  page.kind = "preview";
  page.relative_path = kPreviewPath;
  page.format = "html";
  page.encoding = "self-contained preview page (three.js inline, maps as 8-bit data: PNGs); open in a browser";
  summary->preview = WritePreviewPage(PreviewOptionsOf(inputs, *summary), textures, listed,
                                      staging / page.relative_path, progress);
  RequireSuccess(*summary->preview, "preview page");
  page.sha256 = Sha256HexOfFile(staging / page.relative_path);
  page.bytes = summary->preview->bytes;
  summary->files[page.kind] = page.relative_path;
  files->push_back(std::move(page));
}

// --- The manifest (material.json) --------------------------------------------

nlohmann::json FileEntryJson(const ExportFile& file) {
  // Documents (.gltf, .bin, .mtlx, the preview page): what each is, no image layout.
  if (file.document || file.format == "html") {
    return {{"path", file.relative_path}, {"format", file.format}, {"content", file.encoding},
            {"sha256", file.sha256}, {"bytes", file.bytes}};
  }
  nlohmann::json entry = {{"path", file.relative_path},
                          {"format", file.format},
                          {"bits_per_sample", file.bits_per_sample},
                          {"sample_type", file.is_float ? "float" : "uint"},
                          {"channels", file.channels},
                          {"width", file.width},
                          {"height", file.height},
                          {"color_space", file.color_space},
                          {"encoding", file.encoding},
                          {"mm_per_pixel", file.mm_per_pixel},
                          {"sha256", file.sha256},
                          {"bytes", file.bytes}};
  if (!file.channel_names.empty()) entry["channel_names"] = file.channel_names;
  for (const auto& [name, value] : file.metadata.attributes) {
    if (name == "scanbench:height_min_mm" || name == "scanbench:height_max_mm") {
      entry[name.substr(std::strlen("scanbench:"))] = std::stod(value);
    }
  }
  return entry;
}

nlohmann::json SourceJson(const ExportInputs& inputs) {
  return {{"session", inputs.session_dir.string()},
          {"sample_name", inputs.session.sample_name},
          {"result", inputs.result_dir.filename().string()},
          {"result_dir", inputs.result_dir.string()},
          {"solver_method", inputs.result_report.value("/solver/method"_json_pointer, std::string())},
          {"result_report_sha256", Sha256HexOfFile(inputs.report_path)}};
}

nlohmann::json GroundTruthJson(const ExportOptions& options, const ExportSummary& summary,
                               const GroundTruthFiles& truth) {
  return {{"height_rms_error_mm", *summary.height_rms_error_mm},
          {"height_reference", options.flatten_normals ? "true normals flattened and integrated with the same options"
                                                       : "true height"},
          {"height_error_measure", "RMS of exported minus reference height after removing their best-fit plane"},
          {"normal_mean_angular_error_deg", summary.flattened_normal_mean_error_deg
                                                ? nlohmann::json(*summary.flattened_normal_mean_error_deg)
                                                : nlohmann::json(nullptr)},
          {"evaluated_on", "sample mask, solved pixels"},
          {"simulated_rig_mm_per_pixel", truth.mm_per_pixel}};
}

// Where the roughness maps came from, with the share of solved pixels from
// each source (only with a specular map; without one it is the normal-variance
// chain alone).
nlohmann::json RoughnessSourceJson(const ExportOptions& options, const ExportSummary& summary) {
  const SpecularRoughnessSummary& s = *summary.specular_roughness;
  const double solved = std::max<double>(1.0, double(s.from_specular + s.blended + s.from_fallback));
  return {{"source", summary.roughness_source},
          {"specular_map", "specular.exr roughness_alpha (GGX) where the solver estimated a lobe"},
          {"normal_variance", "base_roughness " + Fixed(options.gloss.base_roughness, 3) + " at mip 0, the " +
                                  summary.gloss.model + " mip chain's normal variance above it"},
          {"blend", "feathered outside the estimated pixels over blend_width_px in perceptual roughness sqrt(alpha): "
                    "weight smoothstep(1 - d / (w + 1)) on the mean of the estimates nearby"},
          {"blend_width_px", options.specular_roughness.blend_width_px},
          {"pixels", {{"specular_map", s.from_specular}, {"blended", s.blended}, {"normal_variance", s.from_fallback}}},
          {"share_of_solved_pixels",
           {{"specular_map", s.from_specular / solved},
            {"blended", s.blended / solved},
            {"normal_variance", s.from_fallback / solved}}},
          {"encoding", "roughness maps hold GGX alpha; perceptual roughness = sqrt(alpha)"}};
}

nlohmann::json ManifestJson(const ExportOptions& options, const ExportSummary& summary, const ExportInputs& inputs,
                            const std::vector<ExportFile>& files) {
  nlohmann::json manifest;
  manifest["schema"] = kMaterialManifestSchema;
  manifest["schema_version"] = kMaterialManifestSchemaVersion;
  manifest["software_version"] = "scanbench " SCANBENCH_VERSION;
  manifest["created"] = FormatUtcTimestamp(std::chrono::system_clock::now());
  manifest["material"] = summary.material_name;
  manifest["preset"] = summary.preset;
  manifest["normal_convention"] = summary.normal_convention;
  manifest["tangent_frame"] = TangentFrameText(options.normal_convention);
  manifest["width"] = summary.image_width;
  manifest["height"] = summary.image_height;
  manifest["mm_per_pixel"] = summary.mm_per_pixel;
  manifest["mm_per_pixel_source"] = summary.mm_per_pixel_source;
  manifest["source"] = SourceJson(inputs);
  manifest["basecolor"] = {
      {"color_space", inputs.albedo_color.color_space == "linear_rec709"
                          ? (options.basecolor_space == ExportOptions::BasecolorSpace::kAcesCg &&
                                     options.preset == ExportOptions::Preset::kLinearExr
                                 ? "acescg"
                                 : "linear_rec709")
                          : "camera_rgb"},
      {"encoding", BasecolorEncodingName(ExportPresetContentsOf(ExportPresetName(options.preset)))},
      {"color_calibration", inputs.albedo_color.description},
      {"scale", inputs.albedo_color.scale},
      {"scale_source", inputs.albedo_color.scale_source}};
  nlohmann::json file_entries = nlohmann::json::object();
  for (const ExportFile& file : files) file_entries[file.kind] = FileEntryJson(file);
  manifest["files"] = file_entries;
  manifest["options"] = OptionsJson(options);
  manifest["summaries"] = SummariesJson(summary);
  if (summary.specular_roughness) manifest["roughness"] = RoughnessSourceJson(options, summary);
  if (IsEnginePreset(options.preset)) {
    manifest["engine"] = {{"preset", summary.preset},
                          {"roughness", "perceptual roughness = sqrt(GGX alpha) of roughness mip 0"},
                          {"basecolor", "8-bit, sRGB transfer curve"},
                          {"data_maps", "16-bit, linear (import with sRGB off)"},
                          {"documentation", "docs/export.md, Engine presets"}};
  }
  if (summary.height_rms_error_mm) {
    manifest["ground_truth"] = GroundTruthJson(options, summary, *inputs.session.ground_truth);
  }
  manifest["warnings"] = summary.warnings;
  nlohmann::json stages = nlohmann::json::object();
  for (const auto& [stage, stage_time] : summary.stage_seconds) stages[stage] = stage_time;
  manifest["timings_s"] = stages;
  return manifest;
}

}  // namespace

void ExportOptions::Check() const {
  static const std::regex kName("[A-Za-z0-9_-][A-Za-z0-9._-]*");
  if (!material_name.empty() && !std::regex_match(material_name, kName)) {
    throw FieldError(kWhere, "material_name", "'" + material_name + "'",
                     "must be letters, digits, '.', '_' or '-' only, not starting with '.'");
  }
  SCANBENCH_REQUIRE_FINITE_GE(kWhere, "mm_per_pixel", mm_per_pixel, 0, "(0 = from the session's rig)");
  if (gltf_displaced_mesh && preset != Preset::kGltf) {
    throw FieldError(kWhere, "gltf_displaced_mesh", "true",
                     std::string("needs preset gltf (the preset is ") + ExportPresetName(preset) + ")");
  }
  if (gltf_mesh_max_vertices < 4 || gltf_mesh_max_vertices > 65536) {
    throw FieldError(kWhere, "gltf_mesh_max_vertices", gltf_mesh_max_vertices, "must be in [4, 65536]");
  }
  flattening.Check();
  // Their mm_per_pixel is replaced by the export's scale: checked at that
  // scale when it is given, else at 1 mm (the rig's scale is known only in Run).
  HeightFromNormalsOptions height_scaled = height;
  AmbientOcclusionOptions occlusion_scaled = occlusion;
  CavityOptions cavity_scaled = cavity;
  height_scaled.mm_per_pixel = occlusion_scaled.mm_per_pixel = cavity_scaled.mm_per_pixel =
      mm_per_pixel > 0 ? mm_per_pixel : 1.0;
  height_scaled.Check();
  occlusion_scaled.Check();
  cavity_scaled.Check();
  gloss.Check();
  specular_roughness.Check();
  if (tileable) tile.Check();  // the crop's options matter only when there is a crop (issue #36)
}

const char* ExportPresetName(ExportOptions::Preset preset) {
  switch (preset) {
    case ExportOptions::Preset::kLinearExr: return "exr";
    case ExportOptions::Preset::kPng16: return "png16";
    case ExportOptions::Preset::kTiff16: return "tiff16";
    case ExportOptions::Preset::kUnreal: return "unreal";
    case ExportOptions::Preset::kUnityHdrp: return "unity-hdrp";
    case ExportOptions::Preset::kGltf: return "gltf";
  }
  return "unknown";
}

bool IsEnginePreset(ExportOptions::Preset preset) { return EngineTargetOf(preset).has_value(); }

ExportOptions::Preset ExportPresetFromName(const std::string& name) {
  using P = ExportOptions::Preset;
  for (auto preset : {P::kLinearExr, P::kPng16, P::kTiff16, P::kUnreal, P::kUnityHdrp, P::kGltf}) {
    if (name == ExportPresetName(preset)) return preset;
  }
  throw std::invalid_argument("export preset '" + name + "' must be exr, png16, tiff16, unreal, unity-hdrp or gltf");
}

const char* NormalConventionName(ExportOptions::NormalConvention convention) {
  return convention == ExportOptions::NormalConvention::kDirectX ? "directx" : "opengl";
}

ExportOptions::NormalConvention NormalConventionFromName(const std::string& name) {
  if (name == "opengl") return ExportOptions::NormalConvention::kOpenGl;
  if (name == "directx") return ExportOptions::NormalConvention::kDirectX;
  throw std::invalid_argument("normal convention '" + name + "' must be opengl or directx");
}

const char* BasecolorSpaceName(ExportOptions::BasecolorSpace space) {
  return space == ExportOptions::BasecolorSpace::kAcesCg ? "acescg" : "rec709";
}

ExportOptions::BasecolorSpace BasecolorSpaceFromName(const std::string& name) {
  if (name == "rec709") return ExportOptions::BasecolorSpace::kLinearRec709;
  if (name == "acescg") return ExportOptions::BasecolorSpace::kAcesCg;
  throw std::invalid_argument("base colour space '" + name + "' must be rec709 or acescg");
}

std::string ExportSummary::FullReport() const {
  std::ostringstream out;
  out << std::fixed << std::setprecision(3);
  out << "scanbench export report\n"
      << "  material:     " << material_name << " (" << preset << ", normals " << normal_convention
      << (normal_convention == "directx" ? " -Y" : " +Y") << "), " << image_width << "x" << image_height << "\n"
      << "  export:       " << export_dir.string() << "\n"
      << "  source:       " << result_dir.string() << "\n"
      << std::setprecision(6) << "  scale:        " << mm_per_pixel << " mm per pixel (" << mm_per_pixel_source
      << ")\n"
      << std::setprecision(3);
  if (flattening.termination == Termination::kSuccess) {
    out << "  flattening:   removed low-frequency tilt mean " << flattening.mean_removed_tilt_deg << " deg, max "
        << flattening.max_removed_tilt_deg << " deg over " << flattening.valid_pixels << " px\n";
  } else {
    out << "  flattening:   off\n";
  }
  out << "  height (" << height.method << "): " << height.levels << " levels, " << height.total_sweeps
      << " sweeps, " << (height.converged ? "converged" : "not converged") << ", RMS slope residual "
      << height.rms_slope_residual << "; range " << height_min_mm << " .. " << height_max_mm << " mm\n"
      << "  ambient occlusion: mean " << occlusion.mean << ", min " << occlusion.min << ", max " << occlusion.max
      << "\n"
      << "  cavity:       mean " << cavity.mean << ", min " << cavity.min << ", max " << cavity.max << "\n"
      << "  roughness mips (" << gloss.model << "): " << gloss.mean_roughness.size() << " levels, mean GGX alpha";
  for (size_t k = 0; k < gloss.mean_roughness.size() && k < 4; ++k) out << " " << gloss.mean_roughness[k];
  if (gloss.mean_roughness.size() > 4) out << " ... " << gloss.mean_roughness.back();
  out << "\n";
  if (specular_roughness) {
    out << "  roughness source: specular.exr at " << specular_roughness->from_specular << " px, blended at "
        << specular_roughness->blended << ", normal variance at " << specular_roughness->from_fallback << "\n";
  }
  if (tile) out << "  tileable crop: " << TerminationName(tile->termination) << ": " << tile->message << "\n";
  if (preview) out << "  preview page: " << preview->BriefReport() << "\n";
  if (height_rms_error_mm) {
    out << "  vs ground truth on the sample: height RMS error " << std::setprecision(4) << *height_rms_error_mm
        << (flattening.termination == Termination::kSuccess
                ? " mm (vs the true normals flattened and integrated alike, best-fit plane removed)"
                : " mm (vs the true height, best-fit plane removed)");
    if (flattened_normal_mean_error_deg) {
      out << ", " << (flattening.termination == Termination::kSuccess ? "flattened " : "")
          << "normal mean angular error " << std::setprecision(3) << *flattened_normal_mean_error_deg << " deg";
    }
    out << "\n";
  }
  for (const std::string& warning : warnings) out << "  warning: " << warning << "\n";
  out << std::setprecision(3) << "  files:        " << files.size() << "\n  time per stage (s):";
  for (const auto& [stage, stage_time] : stage_seconds) out << " " << stage << " " << Significant(stage_time) << ";";
  out << " total " << Significant(seconds) << "\n";
  return out.str();
}

ExportController::ExportController(fs::path result_dir, ExportOptions options)
    : result_dir_(std::move(result_dir)), options_(std::move(options)) {}

// The roughness chain (specular roughness, gloss mips) on a thread of its
// own from the flattening on; DeriveConcurrently waits for it and rethrows its
// failure. Destroyed before the inputs and maps it uses (it is declared after
// them), its future waits for the thread.
struct ExportController::RoughnessStep {
  std::vector<StageTiming> timings;
  std::exception_ptr failure;
  std::future<void> done;
};

// The generic presets' normal file (EarlyNormalFile), written on a thread of
// its own once the normals are final; declared after the maps it borrows, its
// future waits for the write.
struct ExportEarlyNormal {
  std::optional<ExportFile> file;  // none: written with the rest
  std::future<void> written;
};

// Each full-size image is loaded when first needed and released after its
// last user: albedo and confidence only after the derived maps and the
// evaluation (their own full-size temporaries), the solved normals once
// flattened. The evaluation's full-size work (the true normals flattened and
// integrated) runs right after the flattening, before the other maps exist,
// and keeps only the reference height for after the export's own. The
// threads beside the steps are waited for before what they use goes: each
// future is declared after it.
void ExportController::Run() {
  Prepare();
  const auto start = std::chrono::steady_clock::now();
  std::vector<StageTiming>& timings = summary_.stage_seconds;
  ExportInputs inputs = TimedStage(timings, "load", "", [&] { return Load(); });
  const fs::path root = options_.output_root.empty() ? inputs.session_dir / "exports" : options_.output_root;
  // <root>/<result>-<preset>[-N], complete or absent; a root made here and left empty goes again.
  StagedFolder staged =
      StagedFolder::ReserveNumbered(root, inputs.result_dir.filename().string() + "-" + summary_.preset);
  fs::create_directory(staged.staging() / summary_.material_name);

  std::future<DecodedTruth> truth = StartDecodingTruth(inputs);
  ExportMaps maps = Flatten(&inputs);
  ExportEarlyNormal early_normal;
  StartWritingNormal(staged.staging(), inputs, maps, &early_normal);
  std::optional<HeightReference> reference;
  if (truth.valid()) {
    TimedStage(timings, "evaluate", "", [&] { reference = EvaluateNormals(inputs, maps, truth.get()); });
  }
  RoughnessStep roughness;
  StartRoughness(&inputs, &maps, &roughness);
  DeriveHeight(&inputs, &maps);
  DeriveConcurrently(&inputs, &maps, reference ? &*reference : nullptr, &roughness);
  reference.reset();
  if (options_.tileable) TimedStage(timings, "tileable_crop", "tileable crop", [&] { DeriveTile(inputs, &maps); });

  std::vector<ExportFile> files;
  std::future<PreviewPageTextures> preview_textures;  // made while the files are written
  TimedStage(timings, "write_files", "write files", [&] {
    files = WriteFiles(staged.staging(), &inputs, &maps, &early_normal, &preview_textures);
  });
  if (options_.preview_page) {
    // What the page took after the files: the rest of the textures, then the page.
    TimedStage(timings, "preview", "preview page", [&] {
      WritePreview(staged.staging(), inputs, preview_textures.get(), StageCallback("preview page"), &files,
                   &summary_);
    });
  }
  summary_.export_dir = staged.final_dir();
  summary_.seconds = SecondsSince(start);
  WriteManifestAndSummary(staged.staging(), inputs, files);
  ThrowIfStopRequested("write files");
  staged.Commit();
  ReportProgress("write files", 1);
}

// The options checked, an engine preset's own normal convention (whatever was
// asked), a fresh summary.
void ExportController::Prepare() {
  options_.Check();
  if (const auto engine = EngineTargetOf(options_.preset)) {
    options_.normal_convention = EngineNormalIsDirectX(*engine) ? ExportOptions::NormalConvention::kDirectX
                                                                : ExportOptions::NormalConvention::kOpenGl;
  }
  summary_ = ExportSummary();
  summary_.preset = ExportPresetName(options_.preset);
  summary_.normal_convention = NormalConventionName(options_.normal_convention);
}

// The ground truth (simulated sessions; none otherwise) decoded on a thread of
// its own while the normals are flattened (a decoder is mostly single-threaded).
std::future<ExportController::DecodedTruth> ExportController::StartDecodingTruth(const ExportInputs& inputs) const {
  if (!inputs.session.ground_truth) return {};
  return std::async(std::launch::async, [this, &inputs] { return DecodeTruth(inputs); });
}

// The normal map is final once flattened: its file (generic presets) is
// written beside the evaluation and the height, which leave a core mostly idle.
void ExportController::StartWritingNormal(const fs::path& staging, const ExportInputs& inputs,
                                          const ExportMaps& maps, ExportEarlyNormal* early) {
  early->file = EarlyNormalFile(options_, summary_, inputs, maps);
  if (!early->file) return;
  early->written = std::async(std::launch::async, [staging, early] {
    WriteExportFile(staging / early->file->relative_path, *early->file);
  });
}

// The roughness chain needs only the flattened normals (and the specular
// map): it runs beside the height, which leaves a core partly idle, instead
// of beside the occlusion, which does not. (Beside the evaluation too, the
// peak rose to 1.50 GB: the evaluation's full-size work and the chain's.)
void ExportController::StartRoughness(ExportInputs* inputs, ExportMaps* maps, RoughnessStep* roughness) {
  roughness->done = std::async(std::launch::async, [this, inputs, maps, roughness] {
    try {
      DeriveRoughness(inputs, maps, &roughness->timings, [this](double) { return !IsStopRequested(); });
    } catch (...) {
      roughness->failure = std::current_exception();
    }
  });
}

// Every file of the plan into `staging`, concurrently, but the normal file
// written early (once its write ended; the plan must hold the same file); the
// preview's textures (a downsample and PNGs per map, mostly single-threaded)
// on a thread of their own meanwhile. Then the files' hashes and sizes; the
// maps whose only users were files are freed.
std::vector<ExportFile> ExportController::WriteFiles(const fs::path& staging, ExportInputs* inputs, ExportMaps* maps,
                                                     ExportEarlyNormal* early_normal,
                                                     std::future<PreviewPageTextures>* preview_textures) {
  std::vector<ExportFile> files = PlanFiles(options_, summary_, *inputs, *maps);
  std::string written_kind;
  if (early_normal->written.valid()) {
    early_normal->written.get();  // rethrows its failure
    written_kind = early_normal->file->kind;
    const auto planned =
        std::find_if(files.begin(), files.end(), [&](const ExportFile& f) { return f.kind == written_kind; });
    if (planned == files.end() || planned->relative_path != early_normal->file->relative_path) {
      throw std::logic_error("export plan's normal file differs from the one written early");
    }
  }
  if (options_.preview_page) {
    const ProgressCallback stop_check = [this](double) { return !IsStopRequested(); };
    *preview_textures = std::async(std::launch::async, [this, staging, inputs, maps, stop_check] {
      return PreviewTexturesOf(staging, *inputs, *maps, summary_, stop_check);
    });
  }
  WriteFilesConcurrently(
      staging, files, [this](double fraction) { ReportProgress("write files", fraction); }, written_kind);
  ThrowIfStopRequested("write files");
  RecordWrittenFiles(staging, &files, &summary_);
  for (ExportFile& file : files) file.float_image.reset(), file.u8_image.reset();  // written
  inputs->confidence = ImageF();
  maps->cavity = ImageF();
  maps->tiles.clear();
  return files;
}

// material.json (listing `files`) and summary.txt, the last files of the export.
void ExportController::WriteManifestAndSummary(const fs::path& staging, const ExportInputs& inputs,
                                               const std::vector<ExportFile>& files) {
  const nlohmann::json manifest = ManifestJson(options_, summary_, inputs, files);
  summary_.files["manifest"] = "material.json";
  summary_.files["summary"] = "summary.txt";
  WriteFileAtomic(staging / "material.json", manifest.dump(2) + "\n", OverwritePolicy::kRefuse);
  WriteFileAtomic(staging / "summary.txt", summary_.FullReport(), OverwritePolicy::kRefuse);
}

// The result folder, its session, report and maps; the scale and the material name.
ExportInputs ExportController::Load() {
  BeginStage("load result");
  ExportInputs inputs;
  inputs.result_dir = NormalisedResultDir(result_dir_);
  summary_.result_dir = inputs.result_dir;
  CheckIsResultFolder(inputs.result_dir);
  inputs.session_dir = inputs.result_dir.parent_path().parent_path();
  SessionLoadOptions load_options;
  load_options.verify_checksums = false;  // the frames are not read; the solve verified them
  inputs.session = LoadSession(inputs.session_dir, load_options);
  const int width = inputs.session.camera.width, height = inputs.session.camera.height;
  summary_.image_width = width;
  summary_.image_height = height;

  inputs.report_path = inputs.result_dir / "report.json";
  inputs.result_report = ReadJsonFile(inputs.report_path);
  inputs.albedo_color = AlbedoColorOfReport(inputs.result_report.dump());
  // The files decode concurrently (each decoder is mostly single-threaded).
  const fs::path& dir = inputs.result_dir;
  auto normals = std::async(std::launch::async, [&] { return ReadResultMap(dir / "normal.exr", 3, width, height); });
  auto valid = std::async(std::launch::async, [&] { return ReadBinaryMask(dir / "solved_mask.png", width, height); });
  if (fs::exists(dir / "specular.exr")) inputs.specular_alpha = ReadSpecularAlpha(dir / "specular.exr", width, height);
  inputs.valid = valid.get();
  inputs.solved_normals = normals.get();
  ReportProgress("load result", 1);

  ResolveScale(inputs.session, inputs.session_dir, options_.mm_per_pixel, &summary_);
  summary_.material_name = options_.material_name.empty() ? MaterialNameFromSample(inputs.session.sample_name)
                                                          : options_.material_name;
  return inputs;
}

// albedo.exr and confidence.exr (by channel name), decoded concurrently.
// No progress of its own: it runs beside the occlusion.
void ExportController::LoadAlbedoAndConfidence(ExportInputs* inputs) {
  ThrowIfStopRequested("load albedo and confidence");
  const int width = summary_.image_width, height = summary_.image_height;
  const fs::path& dir = inputs->result_dir;
  auto albedo = std::async(std::launch::async, [&] { return ReadResultMap(dir / "albedo.exr", 3, width, height); });
  inputs->confidence = ReadResultMap(dir / "confidence.exr", 3, width, height, ConfidenceChannelNames());
  inputs->albedo = albedo.get();
}

// The flattened normals (or the solved ones as they are), a stage of its own;
// the solved normals are released (or moved) once flattened.
ExportMaps ExportController::Flatten(ExportInputs* inputs_to_release) {
  ExportInputs& inputs = *inputs_to_release;
  std::vector<StageTiming>& timings = summary_.stage_seconds;
  ExportMaps maps;
  if (options_.flatten_normals) {
    TimedStage(timings, "flatten", "flatten normals", [&] {
      summary_.flattening = FlattenNormals(options_.flattening, inputs.solved_normals, &inputs.valid,
                                           &maps.normals, StageCallback("flatten normals"));
      RequireSuccess(summary_.flattening, "flatten normals");
    });
    inputs.solved_normals = ImageF();
  } else {
    maps.normals = std::move(inputs.solved_normals);
  }
  return maps;
}

// Height from the flattened normals, a stage of its own.
void ExportController::DeriveHeight(ExportInputs* inputs, ExportMaps* maps) {
  const double mm = summary_.mm_per_pixel;
  TimedStage(summary_.stage_seconds, "height", "height from normals", [&] {
    summary_.height = HeightFromNormals(ScaledHeightOptions(options_, mm), maps->normals, &inputs->valid,
                                       &maps->height_mm, StageCallback("height from normals"));
    RequireSuccess(summary_.height, "height from normals");
    const float* heights = maps->height_mm.data();
    const auto [lowest, highest] = std::minmax_element(heights, heights + maps->height_mm.size());
    summary_.height_min_mm = *lowest;
    summary_.height_max_mm = *highest;
  });
}

// Occlusion on this thread (it reports the progress); cavity, the end of the
// roughness chain (begun in Run) followed by albedo and confidence, and the
// height's evaluation on threads of their own, which only check for a stop (one progress stage at a
// time). Each records its wall time under its own stage name, so the
// concurrent stages' times overlap. The first failure is rethrown once every
// step has ended (the steps catch their own: their futures never throw).
void ExportController::DeriveConcurrently(ExportInputs* inputs_in, ExportMaps* maps_in,
                                          const HeightReference* reference, RoughnessStep* roughness) {
  ExportInputs& inputs = *inputs_in;
  ExportMaps& maps = *maps_in;
  const double mm = summary_.mm_per_pixel;
  // A failed step ends the others at their next check, as a stop would. Its
  // error is kept before `failed` is set, so that it, not the others'
  // cancellation that follows from it, is the one rethrown.
  std::atomic<bool> failed{false};
  std::mutex failure_mutex;
  std::exception_ptr failure;
  auto record_failure = [&](std::exception_ptr error) {
    std::lock_guard lock(failure_mutex);
    if (!failure) failure = std::move(error);
    failed = true;
  };
  const ProgressCallback stop_check = [this, &failed](double) { return !IsStopRequested() && !failed; };
  auto failing = [&record_failure](auto&& step) {
    return [&record_failure, step] {
      try {
        step();
      } catch (...) {
        record_failure(std::current_exception());
      }
    };
  };
  std::vector<StageTiming> occlusion_timing, cavity_timing, evaluate_timing;
  auto timed = [this](std::vector<StageTiming>& timings, const std::string& name, auto&& step) {
    TimedStage(timings, name, "", step);
  };

  std::shared_future<void> cavity = std::async(std::launch::async, failing([&] {
    timed(cavity_timing, "cavity", [&] {
      CavityOptions cavity_options = options_.cavity;
      cavity_options.mm_per_pixel = mm;
      summary_.cavity = CavityFromHeight(cavity_options, maps.height_mm, &maps.cavity, stop_check);
      RequireSuccess(summary_.cavity, "cavity");
    });
  })).share();
  // Albedo and confidence (400 MB at 16 MP, and their decoders' buffers)
  // only once the cavity's full-size temporaries are gone too.
  auto roughness_then_inputs = std::async(std::launch::async, failing([&, cavity_done = cavity] {
    roughness->done.get();
    if (roughness->failure) std::rethrow_exception(roughness->failure);
    cavity_done.wait();
    timed(roughness->timings, "load_albedo_confidence", [&] { LoadAlbedoAndConfidence(&inputs); });
  }));
  std::future<void> evaluate;
  if (reference) {
    evaluate = std::async(std::launch::async, failing([&] {
      timed(evaluate_timing, "evaluate_height", [&] { EvaluateHeight(*reference, maps); });
    }));
  }
  try {
    TimedStage(occlusion_timing, "occlusion", "ambient occlusion", [&] {
      AmbientOcclusionOptions occlusion_options = options_.occlusion;
      occlusion_options.mm_per_pixel = mm;
      const ProgressCallback report = StageCallback("ambient occlusion");
      summary_.occlusion = AmbientOcclusionFromHeight(
          occlusion_options, maps.height_mm, &maps.occlusion,
          [&](double fraction) { return report(fraction) && !failed; });
      RequireSuccess(summary_.occlusion, "ambient occlusion");
    });
  } catch (...) {
    record_failure(std::current_exception());
  }
  cavity.wait();
  roughness_then_inputs.wait();
  if (evaluate.valid()) evaluate.wait();
  if (failure) std::rethrow_exception(failure);
  for (const auto* timings : {&occlusion_timing, &cavity_timing, &roughness->timings, &evaluate_timing}) {
    summary_.stage_seconds.insert(summary_.stage_seconds.end(), timings->begin(), timings->end());
  }
}

// Mip 0's roughness from the specular map (when the result has one), then
// the roughness mips from the flattened normals; `progress` only checks for a
// stop (these run beside the occlusion).
void ExportController::DeriveRoughness(ExportInputs* inputs_in, ExportMaps* maps_in,
                                       std::vector<StageTiming>* timings, const ProgressCallback& progress) {
  ExportInputs& inputs = *inputs_in;
  ExportMaps& maps = *maps_in;
  ImageF mip0_roughness;  // with a specular map: its alpha feathered into the base roughness
  if (!inputs.specular_alpha.empty()) {
    TimedStage(*timings, "specular_roughness", "", [&] {
      // Mip 0 of today's normal-variance chain is base_roughness everywhere;
      // the chain folds the normal variance into the coarser levels on top of
      // whatever mip 0 holds.
      const ImageF base(summary_.image_width, summary_.image_height, 1,
                        static_cast<float>(options_.gloss.base_roughness));
      summary_.specular_roughness = BlendSpecularRoughness(options_.specular_roughness, inputs.specular_alpha, base,
                                                           &inputs.valid, &mip0_roughness, progress);
      RequireSuccess(*summary_.specular_roughness, "specular roughness");
      summary_.roughness_source = "specular_map+normal_variance";
    });
    inputs.specular_alpha = ImageF();  // its last user
  }
  // Mip 0's normals are the flattened normals normalised again; the files and
  // the preview take maps.normals, so they are not made (192 MB at 16 MP).
  GlossMipOptions gloss = options_.gloss;
  gloss.mip0_normals = false;
  TimedStage(*timings, "gloss_mips", "", [&] {
    summary_.gloss = BuildGlossMipChain(gloss, maps.normals,
                                        mip0_roughness.empty() ? nullptr : &mip0_roughness, &inputs.valid,
                                        &maps.mips, progress);
    RequireSuccess(summary_.gloss, "roughness mips");
  });
}

// A tile that does not fit is a warning, not a failure: the other maps stand.
void ExportController::DeriveTile(const ExportInputs& inputs, ExportMaps* maps) {
  const std::vector<TileableMapInput> tile_inputs = TileInputs(inputs, *maps);
  summary_.tile =
      MakeTileableCrop(options_.tile, tile_inputs, &inputs.valid, &maps->tiles, StageCallback("tileable crop"));
  if (summary_.tile->IsCancelled()) throw Cancelled("tileable crop");
  if (!summary_.tile->IsUsable() || maps->tiles.size() != tile_inputs.size()) {
    summary_.warnings.push_back("no tileable crop: " + summary_.tile->message);
    maps->tiles.clear();
  }
  ReportProgress("tileable crop", 1);
}

// Against the simulated rig's ground truth, on the solved sample pixels.
// Flattening removes the low frequencies of the height on purpose, and no
// clean cut separates them from the weave (the folds' wavelengths are a few
// sigma), so the reference is the true normals through the same flattening
// and integration: the figure is what the solve's normal error does to the
// exported height. Unflattened, the reference is the true height itself.
// The ground truth's normals and sample mask, and its height when that is the
// reference (unflattened): flattened, the true height is derived from the
// flattened true normals like the export's.
ExportController::DecodedTruth ExportController::DecodeTruth(const ExportInputs& inputs) const {
  const GroundTruthFiles& truth = *inputs.session.ground_truth;
  const int width = summary_.image_width, height = summary_.image_height;
  DecodedTruth decoded;
  decoded.normals = ReadGroundTruthMap(inputs.session_dir / truth.normal_file, 3, width, height);
  decoded.on_sample = ReadBinaryMask(inputs.session_dir / truth.mask_file, width, height);
  if (!options_.flatten_normals) {
    decoded.height_mm = ReadGroundTruthMap(inputs.session_dir / truth.height_file, 1, width, height);
  }
  return decoded;
}

ExportController::HeightReference ExportController::EvaluateNormals(const ExportInputs& inputs,
                                                                    const ExportMaps& maps, DecodedTruth truth) {
  BeginStage("ground truth");
  ImageF reference_normals = std::move(truth.normals);
  ImageU8 evaluated = std::move(truth.on_sample);
  for (size_t i = 0; i < evaluated.num_pixels(); ++i) {
    evaluated.data()[i] = evaluated.data()[i] && inputs.valid.data()[i];
  }
  ImageF reference_height;
  if (!options_.flatten_normals) {
    reference_height = std::move(truth.height_mm);
  } else {
    ImageF flattened;
    RequireSuccess(FlattenNormals(options_.flattening, reference_normals, &inputs.valid, &flattened),
                   "ground truth: flatten true normals");
    reference_normals = std::move(flattened);  // the true normals' last user
    ReportProgress("ground truth", 0.3);
    RequireSuccess(HeightFromNormals(ScaledHeightOptions(options_, summary_.mm_per_pixel), reference_normals,
                                     &inputs.valid, &reference_height,
                                     SubRange(StageCallback("ground truth"), 0.3, 1.0)),
                   "ground truth: height from true normals");
  }
  if (const std::optional<double> mean = MeanAngularErrorDegrees(maps.normals, reference_normals, evaluated)) {
    summary_.flattened_normal_mean_error_deg = *mean;
  }
  ReportProgress("ground truth", 1);
  return {std::move(reference_height), std::move(evaluated)};
}

// The exported height against the reference, once the export's height exists.
void ExportController::EvaluateHeight(const HeightReference& reference, const ExportMaps& maps) {
  BeginStage("ground truth");
  summary_.height_rms_error_mm = RmsAfterBestFitPlane(maps.height_mm, reference.height_mm, reference.evaluated);
  ReportProgress("ground truth", 1);
}

}  // namespace scanbench
