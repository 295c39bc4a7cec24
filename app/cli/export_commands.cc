// export: derived maps of a solve (flattened normals, height, occlusion,
// cavity, roughness mips, tileable crop) written for a material pipeline.
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>

#include "app/cli/command_util.h"
#include "app/cli/commands.h"
#include "app/cli/run_controller.h"
#include "app/controllers/export_controller.h"
#include "app/io/export_contents.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

// A CLI11 check from a FromName function that throws with a message.
template <typename FromName>
std::function<std::string(const std::string&)> NameCheck(FromName from_name) {
  return [from_name](const std::string& name) {
    try {
      from_name(name);
      return std::string();
    } catch (const std::exception& error) {
      return std::string(error.what());
    }
  };
}

void AddExportOptions(CLI::App& command, ExportOptions& options) {
  command
      .add_option_function<std::string>(
          "--preset", [&options](const std::string& name) { options.preset = ExportPresetFromName(name); },
          ExportPresetHelp())  // app/io/export_contents.h: the table the GUI's dialog and docs/export.md show
      ->check(NameCheck(ExportPresetFromName));
  command
      .add_option_function<std::string>(
          "--normal-convention",
          [&options](const std::string& name) { options.normal_convention = NormalConventionFromName(name); },
          "Normal map Y for png16/tiff16/exr: opengl (+Y up, default) or directx (Y flipped); the engine presets use "
          "their engine's (unreal: directx, unity-hdrp and gltf: opengl)")
      ->check(NameCheck(NormalConventionFromName));
  command
      .add_option_function<std::string>(
          "--basecolor-space",
          [&options](const std::string& name) { options.basecolor_space = BasecolorSpaceFromName(name); },
          "Primaries of the linear EXR base colour: rec709 (default) or acescg; PNG / TIFF base colour is always "
          "sRGB")
      ->check(NameCheck(BasecolorSpaceFromName));
  SetsField(command.add_option("--material", options.material_name,
                               "Material name, the file-name prefix ([A-Za-z0-9._-]; default: from the sample name)"),
            "ExportOptions.material_name");
  command.add_option("--output", options.output_root, "Folder for the export folders (default: <session>/exports)");
  SetsField(
      command.add_option("--mm-per-pixel", options.mm_per_pixel,
                         "Physical pixel size on the sample, mm (default: from the session's rig at the image centre)"),
      "ExportOptions.mm_per_pixel")
      ->check(CLI::NonNegativeNumber);
  command.add_flag("--no-flatten", [&options](std::int64_t) { options.flatten_normals = false; },
                   "Keep the low-frequency slope (folds, calibration tilt) in the normals and height");
  SetsField(command.add_option("--flatten-sigma", options.flattening.low_pass_sigma_px,
                               "Gaussian sigma of the slope low-pass that flattening removes, px"),
            "NormalFlatteningOptions.low_pass_sigma_px")
      ->capture_default_str();
  CLI::Option* tileable =
      command.add_flag("--tileable", options.tileable, "Also write a seamless tileable crop of every map");
  command.add_flag("--no-preview", [&options](std::int64_t) { options.preview_page = false; },
                   "Do not write preview.html (the sample on a tile and a dome, for a browser)");
  SetsField(command.add_flag("--gltf-displaced-mesh", options.gltf_displaced_mesh,
                             "With --preset gltf: also a mesh displaced by the height map, beside the flat tile"),
            "ExportOptions.gltf_displaced_mesh");
  SetsField(
      command.add_option("--gltf-mesh-vertices", options.gltf_mesh_max_vertices,
                         "Vertex budget of the displaced mesh (4 .. 65536; the grid step is the coarsest that fits)"),
      "ExportOptions.gltf_mesh_max_vertices")
      ->capture_default_str();
  SetsField(command.add_option("--tile-size", options.tile.tile_width,
                               "Tile width and height, px (0 = the largest power of two that fits)"),
            {"TileableCropOptions.tile_width", "TileableCropOptions.tile_height"})
      ->capture_default_str()
      ->needs(tileable);
  SetsField(command.add_option("--tile-blend", options.tile.blend_width_px,
                               "Width of the cross-fade band at each seam of the tile, px (at most the tile size)"),
            "TileableCropOptions.blend_width_px")
      ->capture_default_str()
      ->needs(tileable);
  command
      .add_option_function<std::string>(
          "--height-method",
          [&options](const std::string& name) { options.height.method = HeightMethodFromName(name); },
          "Height from normals: dct (Poisson, default) or relaxation (multi-resolution; slower, same answer)")
      ->check(NameCheck(HeightMethodFromName));
  command
      .add_option_function<std::string>(
          "--gloss-model", [&options](const std::string& name) { options.gloss.model = GlossModelFromName(name); },
          "Roughness mip model: vmf (default) or ggx (shortened normals)")
      ->check(NameCheck(GlossModelFromName));
  SetsField(
      command.add_option("--base-roughness", options.gloss.base_roughness, "GGX alpha of the finest roughness mip"),
      "GlossMipOptions.base_roughness")
      ->capture_default_str();
  SetsField(command.add_option("--ao-radius", options.occlusion.radius_mm, "Ambient occlusion search radius, mm"),
            "AmbientOcclusionOptions.radius_mm")
      ->capture_default_str();
  SetsField(command.add_option("--cavity-radius", options.cavity.radius_mm, "Cavity neighbourhood sigma, mm"),
            "CavityOptions.radius_mm")
      ->capture_default_str();
}

int RunExport(const fs::path& result_dir, const ExportOptions& options) {
  ExportController controller(result_dir, options);
  const int code = RunController(controller);
  if (code == kExitSuccess) std::cout << controller.summary().FullReport();
  return code;
}

}  // namespace

void RegisterExportCommands(CLI::App& app, int* exit_code) {
  auto result_dir = std::make_shared<fs::path>();
  auto options = std::make_shared<ExportOptions>();
  CLI::App* command = app.add_subcommand(
      "export", "Derive height, occlusion, cavity and roughness mips from a solve's result folder and write them with "
                "the normals and albedo for a material pipeline, into a new <session>/exports/<run-id>-<preset>/");
  command->add_option("result", *result_dir, "Result folder (<session>/results/<run-id>)")
      ->required()
      ->check(CLI::ExistingDirectory);
  AddExportOptions(*command, *options);
  command->callback([result_dir, options, exit_code] {
    Guarded(exit_code, [&] { return RunExport(*result_dir, *options); });
  });
}

}  // namespace scanbench
