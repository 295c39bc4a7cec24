// What each file of a material export holds, per preset: the one table that
// the GUI's export dialog, the CLI's `export --preset` help, docs/export.md
// ("Presets") and the export itself (material.json's basecolor encoding and
// each base colour file's colour space) read. The base colour of the integer
// presets is sRGB-encoded, their normals and data maps linear; EXR is linear.
#pragma once

#include <string>
#include <vector>

namespace scanbench {

struct ExportPresetContents {
  const char* name;        // the --preset name: "png16"
  const char* format;      // "16-bit PNG"
  bool basecolor_srgb;     // base colour through the sRGB transfer curve (material.json "srgb_transfer"), else linear
  const char* basecolor;   // "16-bit, sRGB-encoded (Rec.709 primaries)"
  const char* normals;     // "16-bit, linear: (n + 1) / 2"
  const char* data_maps;   // ao, cavity, roughness, normalised height: "16-bit, linear"
  const char* also;        // what else every export of the preset holds
};

// Every preset in the order the dialog and the help list them (the default, png16, first).
const std::vector<ExportPresetContents>& ExportPresetContentsTable();
// Throws std::invalid_argument naming `preset` and the presets there are.
const ExportPresetContents& ExportPresetContentsOf(const std::string& preset);

// material.json's basecolor.encoding: "srgb_transfer" or "linear".
const char* BasecolorEncodingName(const ExportPresetContents& contents);
// The base colour file's colour space (ImageMetadata::color_space, material.json's color_space): "sRGB" or "Linear".
const char* BasecolorColorSpace(const ExportPresetContents& contents);

// One line: "png16 — 16-bit PNG" (the dialog's choice).
std::string ExportPresetTitle(const ExportPresetContents& contents);
// What the files hold: "base colour 16-bit, sRGB-encoded (Rec.709 primaries); normals 16-bit,
// linear: (n + 1) / 2; data maps 16-bit, linear; also …".
std::string ExportPresetHolds(const ExportPresetContents& contents);
// The CLI's --preset help: every preset with what its files hold.
std::string ExportPresetHelp();
// docs/export.md's preset table (Markdown, a header and a row per preset).
std::string ExportPresetMarkdownTable();

}  // namespace scanbench
