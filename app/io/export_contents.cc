#include "app/io/export_contents.h"

#include <stdexcept>

namespace scanbench {

namespace {

const std::vector<ExportPresetContents> kTable = {
    {"png16", "16-bit PNG", true, "16-bit, sRGB-encoded (Rec.709 primaries)", "16-bit, linear: (n + 1) / 2",
     "16-bit, linear", "height also as float EXR (mm); an 8-bit sRGB base colour preview"},
    {"tiff16", "16-bit TIFF (zip)", true, "16-bit, sRGB-encoded (Rec.709 primaries)", "16-bit, linear: (n + 1) / 2",
     "16-bit, linear", "height also as float EXR (mm); an 8-bit sRGB base colour preview"},
    {"exr", "32-bit float OpenEXR", false, "float, linear (Rec.709 or, with --basecolor-space acescg, ACEScg)",
     "float, linear: n", "float, linear", "height in mm; an 8-bit sRGB base colour preview; no quantisation"},
    {"unreal", "Unreal Engine: T_<material>_BC / _N / _ORM / _H PNG", true, "8-bit, sRGB-encoded",
     "16-bit, linear, DirectX (+Y down)", "16-bit, linear (ORM: import with sRGB off)", "height also as float EXR (mm)"},
    {"unity-hdrp", "Unity HDRP Lit: _BaseMap / _Normal / _MaskMap / _HeightMap PNG", true, "8-bit, sRGB-encoded",
     "16-bit, linear, OpenGL (+Y up)", "16-bit, linear (mask map: import with sRGB off)",
     "height also as float EXR (mm)"},
    {"gltf", "glTF 2.0 tile (.gltf + .bin) with _baseColor / _normal / _occlusionRoughnessMetallic PNG", true,
     "8-bit, sRGB-encoded", "16-bit, linear, OpenGL (+Y up)", "16-bit, linear", "height also as float EXR (mm)"},
};

}  // namespace

const std::vector<ExportPresetContents>& ExportPresetContentsTable() { return kTable; }

const ExportPresetContents& ExportPresetContentsOf(const std::string& preset) {
  std::string names;
  for (const ExportPresetContents& row : kTable) {
    if (row.name == preset) return row;
    names += std::string(names.empty() ? "" : ", ") + row.name;
  }
  throw std::invalid_argument("export preset '" + preset + "': not one of " + names);
}

const char* BasecolorEncodingName(const ExportPresetContents& contents) {
  return contents.basecolor_srgb ? "srgb_transfer" : "linear";
}

const char* BasecolorColorSpace(const ExportPresetContents& contents) {
  return contents.basecolor_srgb ? "sRGB" : "Linear";
}

std::string ExportPresetTitle(const ExportPresetContents& contents) {
  return std::string(contents.name) + " — " + contents.format;
}

std::string ExportPresetHolds(const ExportPresetContents& contents) {
  return std::string("base colour ") + contents.basecolor + "; normals " + contents.normals + "; data maps " +
         contents.data_maps + "; " + contents.also;
}

std::string ExportPresetHelp() {
  std::string help = "What to write; each preset's files hold:";
  for (const ExportPresetContents& row : kTable) {
    help += std::string(" ") + row.name + (row.name == kTable.front().name ? " (default)" : "") + ": " + row.format +
            ", " + ExportPresetHolds(row) + ".";
  }
  return help + " Every export also writes a MaterialX <material>.mtlx.";
}

std::string ExportPresetMarkdownTable() {
  std::string table =
      "| preset | files | base colour | normals | data maps (ao, cavity, roughness, height) | also |\n"
      "| --- | --- | --- | --- | --- | --- |\n";
  for (const ExportPresetContents& row : kTable) {
    table += std::string("| `") + row.name + "`" + (row.name == kTable.front().name ? " (default)" : "") + " | " +
             row.format + " | " + row.basecolor + " | " + row.normals + " | " + row.data_maps + " | " + row.also +
             " |\n";
  }
  return table;
}

}  // namespace scanbench
