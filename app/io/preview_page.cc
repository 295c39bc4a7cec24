#include "app/io/preview_page.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <future>
#include <span>
#include <string_view>
#include <tuple>

#include <nlohmann/json.hpp>

#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "app/io/preview_page_assets.h"
#include "calibration/color_science.h"
#include "core/field_error.h"
#include "core/format.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

constexpr char kWhere[] = "PreviewPageOptions";
constexpr char kTemplateName[] = "preview_page.html";
constexpr char kThreeName[] = "three.module.min.js";

std::string Base64(std::span<const uint8_t> bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = (uint32_t(bytes[i]) << 16) | (uint32_t(bytes[i + 1]) << 8) | bytes[i + 2];
    for (int shift : {18, 12, 6, 0}) out += kAlphabet[(v >> shift) & 63];
  }
  if (i < bytes.size()) {
    const bool two = i + 1 < bytes.size();
    const uint32_t v = (uint32_t(bytes[i]) << 16) | (two ? uint32_t(bytes[i + 1]) << 8 : 0);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += two ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string PngDataUri(const ImageU8& image) {
  const std::vector<uint8_t> png = EncodePngInMemory(image);
  return "data:image/png;base64," + Base64(png);
}

// The texture size: the long side at most max_px, the aspect kept.
std::pair<int, int> TextureSize(int width, int height, int max_px) {
  const double factor = std::max(1.0, double(std::max(width, height)) / max_px);
  return {std::max(1, int(std::lround(width / factor))), std::max(1, int(std::lround(height / factor)))};
}

template <typename T>
Image<T> Crop(const Image<T>& image, int x0, int y0, int width, int height) {
  Image<T> out(width, height, image.channels());
  for (int y = 0; y < height; ++y) {
    std::copy_n(image.row(y0 + y) + size_t(x0) * image.channels(), size_t(width) * image.channels(), out.row(y));
  }
  return out;
}

// Box average of each texture pixel's source pixels in the region (x0, y0,
// width x height) of `image` (no copy of the region), the solved ones only
// where there are any (unsolved pixels hold placeholders: normal (0, 0, 1),
// albedo 0). `valid` is the whole image's mask, or empty.
ImageF Downsample(const ImageF& image, const ImageU8& valid, int x0, int y0, int width, int height, int out_width,
                  int out_height) {
  if (width == out_width && height == out_height) return Crop(image, x0, y0, width, height);
  const int channels = image.channels();
  // One texture row at a time (its source rows are consecutive): sums of a
  // row's texels only, in the same order as over the whole texture.
  std::vector<double> sum(size_t(out_width) * channels), sum_all(sum.size());
  std::vector<double> count(out_width), count_all(out_width);
  // Each source column's texture column, once (not a division per pixel).
  std::vector<int> column_of(width);
  for (int x = 0; x < width; ++x) column_of[x] = int(int64_t(x) * out_width / width);
  ImageF out(out_width, out_height, channels);
  auto flush = [&](int out_y) {
    float* texel = out.row(out_y);
    for (int o = 0; o < out_width; ++o) {
      for (int c = 0; c < channels; ++c) {
        texel[o * channels + c] = float(count[o] > 0 ? sum[o * channels + c] / count[o]
                                                      : sum_all[o * channels + c] / std::max(1.0, count_all[o]));
      }
    }
    std::fill(sum.begin(), sum.end(), 0.0);
    std::fill(sum_all.begin(), sum_all.end(), 0.0);
    std::fill(count.begin(), count.end(), 0.0);
    std::fill(count_all.begin(), count_all.end(), 0.0);
  };
  int out_y = 0;
  for (int y = 0; y < height; ++y) {
    const int row_of_y = int(int64_t(y) * out_height / height);
    for (; out_y < row_of_y; ++out_y) flush(out_y);
    const float* pixel = image.row(y0 + y) + size_t(x0) * channels;
    const uint8_t* solved_row = valid.empty() ? nullptr : valid.row(y0 + y) + x0;
    for (int x = 0; x < width; ++x, pixel += channels) {
      const size_t o = column_of[x];
      const bool solved = solved_row == nullptr || solved_row[x] != 0;
      for (int c = 0; c < channels; ++c) {
        sum_all[o * channels + c] += pixel[c];
        if (solved) sum[o * channels + c] += pixel[c];
      }
      count_all[o] += 1;
      if (solved) count[o] += 1;
    }
  }
  for (; out_y < out_height; ++out_y) flush(out_y);
  return out;
}


// A non-finite value (never from the export, which checks its inputs) reads 0.
uint8_t ToByte(double unit) {
  return std::isfinite(unit) ? uint8_t(std::lround(std::clamp(unit, 0.0, 1.0) * 255.0)) : 0;
}

// Each float per pixel through `encode` (value -> [0, 1]) into 8 bits.
template <typename Encode>
ImageU8 Encode8(const ImageF& image, Encode encode) {
  ImageU8 out(image.width(), image.height(), image.channels());
  for (size_t i = 0; i < image.size(); ++i) out.data()[i] = ToByte(encode(image.data()[i]));
  return out;
}

// Averaged normals renormalised, then (n + 1) / 2 per component.
ImageU8 EncodeNormals8(const ImageF& normal) {
  ImageU8 out(normal.width(), normal.height(), 3);
  for (size_t i = 0; i < normal.num_pixels(); ++i) {
    const float* n = normal.data() + 3 * i;
    const double length = std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]);
    for (int c = 0; c < 3; ++c) {
      const double unit = length > 1e-6 ? n[c] / length : (c == 2 ? 1.0 : 0.0);
      out.data()[3 * i + c] = ToByte((unit + 1) / 2);
    }
  }
  return out;
}

// Inside <script>, "</" would end the element: JSON allows "<\/".
std::string ScriptSafeJson(const nlohmann::json& json) {
  const std::string text = json.dump();
  std::string safe;
  safe.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    safe += text[i];
    if (text[i] == '<' && i + 1 < text.size() && text[i + 1] == '/') safe += '\\';
  }
  return safe;
}

void ReplaceOnce(std::string* text, std::string_view placeholder, const std::string& value) {
  const size_t at = text->find(placeholder);
  if (at == std::string::npos) {
    throw std::logic_error(std::string(kTemplateName) + ": placeholder " + std::string(placeholder) + " is missing");
  }
  text->replace(at, placeholder.size(), value);
}

std::string_view RequiredAsset(const char* name, const char* source_path) {
  const std::string_view text = PreviewPageAsset(name);
  if (text.empty()) {
    throw std::logic_error(std::string(source_path) + ": was not compiled into scanbench_io (see app/io/CMakeLists.txt)");
  }
  return text;
}

// The maps by reference, a null view as an empty map.
struct PreviewMaps {
  const ImageF& basecolor_linear_rec709;
  const ImageF& normal_in_tangent;
  const ImageF& roughness_alpha;
  const ImageF& occlusion;
  const ImageF& height_mm;
  const ImageU8& valid;
  // The tileable crop; empty maps without one.
  const ImageF& tile_basecolor_linear_rec709;
  const ImageF& tile_normal_in_tangent;
  const ImageF& tile_roughness_alpha;
  const ImageF& tile_occlusion;
  bool has_tile() const { return !tile_basecolor_linear_rec709.empty(); }
};

PreviewMaps MapsOf(const PreviewPageMapViews& views) {
  static const ImageF kNoMap;
  static const ImageU8 kNoMask;
  auto map_of = [](const ImageF* map) -> const ImageF& { return map ? *map : kNoMap; };
  return {map_of(views.basecolor_linear_rec709),
          map_of(views.normal_in_tangent),
          map_of(views.roughness_alpha),
          map_of(views.occlusion),
          map_of(views.height_mm),
          views.valid ? *views.valid : kNoMask,
          map_of(views.tile_basecolor_linear_rec709),
          map_of(views.tile_normal_in_tangent),
          map_of(views.tile_roughness_alpha),
          map_of(views.tile_occlusion)};
}

// Maps that do not fit together are the caller's mistake: thrown (naming the
// page) before any work.
void CheckMaps(const PreviewMaps& maps, double mm_per_pixel, const fs::path& html_path) {
  const ImageF& base = maps.basecolor_linear_rec709;
  const int width = base.width(), height = base.height();
  auto fail = [&](const std::string& why) { return std::invalid_argument(html_path.string() + ": " + why); };
  if (base.empty() || base.channels() != 3) throw fail("basecolor_linear_rec709 must have 3 channels and pixels");
  if (!maps.normal_in_tangent.SameSize(base) || maps.normal_in_tangent.channels() != 3) {
    throw fail("normal_in_tangent is " + ShapeText(maps.normal_in_tangent) + ", " + SizeText(width, height) +
                "x3 expected");
  }
  for (const auto& [name, map] : {std::pair{"roughness_alpha", &maps.roughness_alpha},
                                  std::pair{"occlusion", &maps.occlusion}, std::pair{"height_mm", &maps.height_mm}}) {
    if (!map->empty() && (!map->SameSize(base) || map->channels() != 1)) {
      throw fail(std::string(name) + " is " + ShapeText(*map) + ", " + SizeText(width, height) + "x1 expected");
    }
  }
  if (!maps.valid.empty() && (!maps.valid.SameSize(base) || maps.valid.channels() != 1)) {
    throw fail("valid is " + ShapeText(maps.valid) + ", " + SizeText(width, height) + "x1 expected");
  }
  if (!std::isfinite(mm_per_pixel) || !(mm_per_pixel > 0)) {
    throw fail("mm_per_pixel = " + std::to_string(mm_per_pixel) + " must be finite and > 0");
  }
  const ImageF& tile = maps.tile_basecolor_linear_rec709;
  const bool any_tile = !tile.empty() || !maps.tile_normal_in_tangent.empty() ||
                        !maps.tile_roughness_alpha.empty() || !maps.tile_occlusion.empty();
  if (!any_tile) return;
  if (tile.empty() || tile.channels() != 3) throw fail("tile_basecolor_linear_rec709 must have 3 channels and pixels");
  if (!maps.tile_normal_in_tangent.SameSize(tile) || maps.tile_normal_in_tangent.channels() != 3) {
    throw fail("tile_normal_in_tangent is " + ShapeText(maps.tile_normal_in_tangent) + ", " +
               SizeText(tile.width(), tile.height()) + "x3 expected");
  }
  for (const auto& [name, map] : {std::pair{"tile_roughness_alpha", &maps.tile_roughness_alpha},
                                  std::pair{"tile_occlusion", &maps.tile_occlusion}}) {
    if (!map->empty() && (!map->SameSize(tile) || map->channels() != 1)) {
      throw fail(std::string(name) + " is " + ShapeText(*map) + ", " + SizeText(tile.width(), tile.height()) +
                 "x1 expected");
    }
  }
}

// The whole frame's textures cover the whole map; the sample's the tileable
// crop (its own maps) or else a centred crop, sphere_crop of each side, in
// their own smaller textures.
struct TextureLayout {
  int width = 0, height = 0;             // of the maps
  int tile_width = 0, tile_height = 0;   // of the whole frame's textures
  int crop_x = 0, crop_y = 0, crop_width = 0, crop_height = 0;  // the centred crop, or the tileable crop's size
  int sphere_width = 0, sphere_height = 0;  // of the sample's textures
  bool tileable = false;
};

TextureLayout LayoutOf(const PreviewPageOptions& options, int width, int height, const ImageF& tile) {
  TextureLayout layout;
  layout.width = width;
  layout.height = height;
  std::tie(layout.tile_width, layout.tile_height) = TextureSize(width, height, options.max_texture_px);
  layout.tileable = !tile.empty();
  layout.crop_width = layout.tileable ? tile.width() : std::max(1, int(std::lround(width * options.sphere_crop)));
  layout.crop_height = layout.tileable ? tile.height() : std::max(1, int(std::lround(height * options.sphere_crop)));
  layout.crop_x = layout.tileable ? 0 : (width - layout.crop_width) / 2;
  layout.crop_y = layout.tileable ? 0 : (height - layout.crop_height) / 2;
  std::tie(layout.sphere_width, layout.sphere_height) =
      TextureSize(layout.crop_width, layout.crop_height, options.max_sphere_texture_px);
  return layout;
}

using Encoder = std::function<ImageU8(const ImageF&)>;

Encoder PerValue(std::function<double(float)> encode) {
  return [encode](const ImageF& image) { return Encode8(image, encode); };
}

struct Texture {
  const char* use;         // the three.js material slot; "" = listed only
  std::string label, note;
  const ImageF* image;
  bool solved_only;        // average the solved pixels only (the mask itself: all)
  bool on_sphere;          // also a texture of the sample
  Encoder encode;
  const ImageF* tile = nullptr;  // the tileable crop's map, the sample's source when there is one
};

// The page's textures in order: the base colour and the normals always, then
// those of the maps given; `solved` is the mask as floats (empty: none).
std::vector<Texture> TexturesOf(const PreviewPageOptions& options, const PreviewMaps& maps, const ImageF& solved,
                                double height_min, double height_max) {
  const double height_range = height_max - height_min;
  const bool tileable = maps.has_tile();
  // With a tileable crop, a map it lacks has no sample texture (the frame's crop would not match the rest).
  auto tile_of = [tileable](const ImageF& map) { return tileable ? &map : nullptr; };
  std::vector<Texture> textures;
  textures.push_back({"map", "base colour",
                      (options.basecolor_note.empty() ? "linear RGB" : options.basecolor_note) +
                          ", shown through the sRGB curve",
                      &maps.basecolor_linear_rec709, true, true, PerValue([](float v) { return SrgbEncode(v); }),
                      tile_of(maps.tile_basecolor_linear_rec709)});
  textures.push_back({"normalMap", "normal", "tangent frame, OpenGL (+Y up), (n + 1) / 2", &maps.normal_in_tangent,
                      true, true, EncodeNormals8, tile_of(maps.tile_normal_in_tangent)});
  if (!maps.roughness_alpha.empty()) {
    // Averaged as GGX alpha, then stored as three.js's perceptual roughness.
    textures.push_back({"roughnessMap", "roughness", "perceptual roughness sqrt(GGX alpha)", &maps.roughness_alpha,
                        true, !tileable || !maps.tile_roughness_alpha.empty(),
                        PerValue([](float alpha) { return std::sqrt(std::max(0.0f, alpha)); }),
                        tile_of(maps.tile_roughness_alpha)});
  }
  if (!maps.occlusion.empty()) {
    textures.push_back({"aoMap", "ambient occlusion", "1 = open; darkens the ambient light", &maps.occlusion, true,
                        !tileable || !maps.tile_occlusion.empty(), PerValue([](float v) { return v; }),
                        tile_of(maps.tile_occlusion)});
  }
  if (!maps.height_mm.empty()) {
    textures.push_back({"", "height", "mm, " + Fixed(height_min, 3) + " .. " + Fixed(height_max, 3) +
                                          " (listed, not displaced)",
                        &maps.height_mm, true, false, PerValue([height_min, height_range](float h) {
                          return height_range > 0 ? (h - height_min) / height_range : 0.5;
                        }), nullptr});
  }
  if (!solved.empty()) {
    // Unweighted, so that a texel is kept when at least half its pixels were solved.
    textures.push_back({"alphaMap", "solved mask", "texels with under half their pixels solved are not drawn", &solved,
                        false, false, PerValue([](float v) { return v >= 0.5f ? 1.0 : 0.0; }), nullptr});
  }
  return textures;
}

// Each texture's PNGs (the tile's, and the sphere's when on it) made
// concurrently (deflate dominates) into `out`; progress up to 0.9 as they
// finish. False when `progress` asked to stop (every one has ended by then).
bool EncodeTextures(const std::vector<Texture>& textures, const ImageU8& valid, const TextureLayout& layout,
                    const ProgressCallback& progress, std::vector<PreviewPageTexture>* out) {
  const TextureLayout& l = layout;
  std::vector<std::future<std::pair<std::string, std::string>>> encoded;
  for (const Texture& texture : textures) {
    encoded.push_back(std::async(std::launch::async, [&, texture] {
      const ImageU8 no_mask;
      const ImageU8& mask = texture.solved_only ? valid : no_mask;
      const ImageF small = Downsample(*texture.image, mask, 0, 0, l.width, l.height, l.tile_width, l.tile_height);
      std::string sphere_uri;
      if (texture.on_sphere && texture.tile != nullptr) {
        // The tileable crop is solved everywhere it was cut (maps/tileable_crop.h): no mask.
        sphere_uri = PngDataUri(texture.encode(
            Downsample(*texture.tile, no_mask, 0, 0, l.crop_width, l.crop_height, l.sphere_width, l.sphere_height)));
      } else if (texture.on_sphere) {
        sphere_uri = PngDataUri(texture.encode(Downsample(*texture.image, mask, l.crop_x, l.crop_y, l.crop_width,
                                                          l.crop_height, l.sphere_width, l.sphere_height)));
      }
      return std::pair{PngDataUri(texture.encode(small)), sphere_uri};
    }));
  }
  bool stop = false;
  for (size_t i = 0; i < encoded.size(); ++i) {
    auto [uri, sphere_uri] = encoded[i].get();  // waits for every one, also after a stop
    out->push_back({textures[i].use, textures[i].label, textures[i].note, std::move(uri), std::move(sphere_uri)});
    if (progress && !progress(0.9 * (i + 1) / encoded.size())) stop = true;
  }
  return !stop;
}

}  // namespace

void PreviewPageOptions::Check() const {
  if (max_texture_px < 16 || max_texture_px > 8192) {
    throw FieldError(kWhere, "max_texture_px", max_texture_px, "must be in [16, 8192] px");
  }
  if (max_sphere_texture_px < 16 || max_sphere_texture_px > 8192) {
    throw FieldError(kWhere, "max_sphere_texture_px", max_sphere_texture_px, "must be in [16, 8192] px");
  }
  if (!(sphere_crop > 0 && sphere_crop <= 1)) {
    throw FieldError(kWhere, "sphere_crop", sphere_crop, "must be in (0, 1]");
  }
}

std::string PreviewPageSummary::BriefReport() const {
  if (termination != Termination::kSuccess) return std::string("preview page: ") + TerminationName(termination) + ": " + message;
  return "preview.html: " + Fixed(bytes / 1e6, 1) + " MB, textures " + SizeText(texture_width, texture_height) +
         ", " + Fixed(seconds, 2) + " s";
}

std::string PreviewPageFragment(bool normal_map, double light_azimuth_deg, double light_elevation_deg, bool panel,
                                bool whole_frame) {
  std::string fragment = "#";
  if (!normal_map) fragment += "normal=off&";
  fragment += "light=" + Fixed(light_azimuth_deg, 0) + "," + Fixed(light_elevation_deg, 0);
  if (!panel) fragment += "&panel=off";
  if (whole_frame) fragment += "&frame=on";
  return fragment;
}

PreviewPageTextures MakePreviewTextures(const PreviewPageOptions& options, const PreviewPageMaps& maps,
                                        double mm_per_pixel, const fs::path& html_path,
                                        const ProgressCallback& progress) {
  return MakePreviewTextures(options, PreviewPageMapViews::Of(maps), mm_per_pixel, html_path, progress);
}

PreviewPageMapViews PreviewPageMapViews::Of(const PreviewPageMaps& maps) {
  PreviewPageMapViews views;
  views.basecolor_linear_rec709 = &maps.basecolor_linear_rec709;
  views.normal_in_tangent = &maps.normal_in_tangent;
  views.roughness_alpha = &maps.roughness_alpha;
  views.occlusion = &maps.occlusion;
  views.height_mm = &maps.height_mm;
  views.valid = &maps.valid;
  return views;
}

PreviewPageTextures MakePreviewTextures(const PreviewPageOptions& options, const PreviewPageMapViews& views,
                                        double mm_per_pixel, const fs::path& html_path,
                                        const ProgressCallback& progress) {
  options.Check();
  const PreviewMaps maps = MapsOf(views);
  CheckMaps(maps, mm_per_pixel, html_path);
  RequiredAsset(kTemplateName, "app/io/preview_page.html");  // missing assets fail before any work
  RequiredAsset(kThreeName, "third_party/three/three.module.min.js");
  const auto start = std::chrono::steady_clock::now();
  PreviewPageTextures made;
  const ImageF& base = maps.basecolor_linear_rec709;
  const TextureLayout layout = LayoutOf(options, base.width(), base.height(), maps.tile_basecolor_linear_rec709);
  made.summary.texture_width = layout.tile_width;
  made.summary.texture_height = layout.tile_height;
  double height_min = 0, height_max = 0;
  if (!maps.height_mm.empty()) {
    const auto [low, high] = std::minmax_element(maps.height_mm.data(), maps.height_mm.data() + maps.height_mm.size());
    height_min = *low;
    height_max = *high;
  }
  ImageF solved;  // the mask as a map of its own (a texture's pixels must be floats)
  if (!maps.valid.empty()) {
    solved = ImageF(base.width(), base.height(), 1);
    for (size_t i = 0; i < solved.num_pixels(); ++i) solved.data()[i] = maps.valid.data()[i] ? 1.0f : 0.0f;
  }
  const std::vector<Texture> textures = TexturesOf(options, maps, solved, height_min, height_max);
  if (!EncodeTextures(textures, maps.valid, layout, progress, &made.textures)) {
    made.textures.clear();
    made.summary.SetCancelled("preview page cancelled; nothing written");
    return made;
  }
  made.mm_per_pixel = mm_per_pixel;
  made.image_width = base.width();
  made.image_height = base.height();
  made.crop_width = layout.crop_width;
  made.crop_height = layout.crop_height;
  made.tileable = layout.tileable;
  made.height_min_mm = height_min;
  made.height_max_mm = height_max;
  made.summary.termination = Termination::kSuccess;
  made.summary.seconds = SecondsSince(start);
  return made;
}

PreviewPageSummary WritePreviewPage(const PreviewPageOptions& options, const PreviewPageTextures& textures,
                                    const std::vector<PreviewPageFile>& files, const fs::path& html_path,
                                    const ProgressCallback& progress) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  PreviewPageSummary summary = textures.summary;
  if (!textures.summary.IsUsable()) {
    throw std::invalid_argument(html_path.string() + ": the preview's textures were not made (" +
                                textures.summary.message + ")");
  }
  const std::string_view page_template = RequiredAsset(kTemplateName, "app/io/preview_page.html");
  const std::string_view three = RequiredAsset(kThreeName, "third_party/three/three.module.min.js");
  nlohmann::json map_entries = nlohmann::json::array();
  for (const PreviewPageTexture& texture : textures.textures) {
    nlohmann::json entry = {{"use", texture.use}, {"label", texture.label}, {"note", texture.note},
                            {"uri", texture.uri}};
    if (!texture.sphere_uri.empty()) entry["sphere_uri"] = texture.sphere_uri;
    map_entries.push_back(std::move(entry));
  }
  const double mm_per_pixel = textures.mm_per_pixel;
  nlohmann::json file_entries = nlohmann::json::array();
  for (const PreviewPageFile& file : files) file_entries.push_back({{"path", file.path}, {"bytes", file.bytes}});
  const std::string title = options.title.empty() ? "scanbench material" : options.title;
  const nlohmann::json data = {{"title", title},
                               {"mm_per_pixel", mm_per_pixel},
                               {"width_mm", textures.image_width * mm_per_pixel},
                               {"height_mm", textures.image_height * mm_per_pixel},
                               {"image", {{"width", textures.image_width}, {"height", textures.image_height}}},
                               {"texture", {{"width", summary.texture_width}, {"height", summary.texture_height}}},
                               {"sample", {{"tileable", textures.tileable},
                                           {"fraction", textures.tileable ? 0.0 : options.sphere_crop},
                                           {"width_px", textures.crop_width},
                                           {"height_px", textures.crop_height},
                                           {"width_mm", textures.crop_width * mm_per_pixel},
                                           {"height_mm", textures.crop_height * mm_per_pixel}}},
                               {"height_range_mm", {textures.height_min_mm, textures.height_max_mm}},
                               {"maps", map_entries},
                               {"files", file_entries}};
  // In this order each placeholder is found in the template, never in what an earlier one put in.
  std::string page(page_template);
  ReplaceOnce(&page, "__SCANBENCH_THREE_MODULE_BASE64__",
              Base64(std::span(reinterpret_cast<const uint8_t*>(three.data()), three.size())));
  ReplaceOnce(&page, "__SCANBENCH_PREVIEW_DATA__", ScriptSafeJson(data));
  ReplaceOnce(&page, "__SCANBENCH_TITLE__", XmlEscaped(title + " — scanbench preview"));
  if (progress && !progress(1.0)) {
    summary.SetCancelled("preview page cancelled; nothing written");
    return summary;
  }
  WriteFileAtomic(html_path, page, OverwritePolicy::kRefuse);
  summary.bytes = page.size();
  summary.termination = Termination::kSuccess;
  summary.seconds += SecondsSince(start);
  return summary;
}

PreviewPageSummary WritePreviewPage(const PreviewPageOptions& options, const PreviewPageMaps& maps,
                                    double mm_per_pixel, const std::vector<PreviewPageFile>& files,
                                    const fs::path& html_path, const ProgressCallback& progress) {
  const PreviewPageTextures textures = MakePreviewTextures(options, maps, mm_per_pixel, html_path, progress);
  if (textures.summary.IsCancelled()) return textures.summary;
  return WritePreviewPage(options, textures, files, html_path, progress);
}

}  // namespace scanbench
