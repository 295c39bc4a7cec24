// The export's preview page (app/io/preview_page.h): what the file holds, and
// how it renders in headless Chromium (Debian's `chromium`, WebGL through
// SwiftShader): not blank, brighter on the lit side, the normal map's detail
// present and in the OpenGL (+Y up) convention. The browser tests skip, naming
// what is missing, when chromium is not installed.
#include "app/io/preview_page.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <numbers>

#include <nlohmann/json.hpp>

#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "tests/util/command_runner.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::TemporaryFolder;

std::string ReadText(const fs::path& path) {
  const std::vector<uint8_t> bytes = ReadFileBytes(path);
  return std::string(bytes.begin(), bytes.end());
}

// The synthetic sample: grey albedo 0.4, normals tilted 15 degrees towards +y
// (the image's top) with ridges across y (period 16 px, slope amplitude 0.5),
// so a light from the top brightens the tile only in the OpenGL convention and
// the normal map is the only source of high frequencies.
constexpr int kWidth = 256, kHeight = 192;
constexpr double kTiltDeg = 15, kRidgeSlope = 0.5, kRidgePeriodPx = 16;

PreviewPageMaps RidgedMaps(int width = kWidth, int height = kHeight) {
  PreviewPageMaps maps;
  maps.basecolor_linear_rec709 = ImageF(width, height, 3, 0.4f);
  maps.normal_in_tangent = ImageF(width, height, 3);
  maps.roughness_alpha = ImageF(width, height, 1, 0.36f);
  maps.occlusion = ImageF(width, height, 1, 1.0f);
  maps.height_mm = ImageF(width, height, 1);
  maps.valid = ImageU8(width, height, 1, 1);
  const double tilt = std::tan(kTiltDeg * std::numbers::pi / 180);
  for (int y = 0; y < height; ++y) {
    // Image rows run down; +y of the tangent frame is up.
    const double slope_y = tilt + kRidgeSlope * std::sin(2 * std::numbers::pi * y / kRidgePeriodPx);
    const double length = std::sqrt(1 + slope_y * slope_y);
    for (int x = 0; x < width; ++x) {
      maps.normal_in_tangent(x, y, 0) = 0;
      maps.normal_in_tangent(x, y, 1) = float(slope_y / length);
      maps.normal_in_tangent(x, y, 2) = float(1 / length);
      maps.height_mm(x, y) = float(0.01 * (height - y));
    }
  }
  return maps;
}

PreviewPageSummary WriteRidgedPage(const fs::path& path, const PreviewPageMaps& maps, PreviewPageOptions options = {}) {
  options.title = "ridged test sample";
  return WritePreviewPage(options, maps, 0.1, {{"ridged/ridged_normal.png", 123456}, {"material.json", 2048}}, path);
}

// The JSON block the page carries.
nlohmann::json PageData(const std::string& page) {
  // Not std::regex: it recurses per character and overflows the stack on megabytes.
  const std::string open = "<script type=\"application/json\" id=\"scanbench-data\">";
  const size_t begin = page.find(open);
  if (begin == std::string::npos) return {};
  const size_t end = page.find("</script>", begin);
  if (end == std::string::npos) return {};
  return nlohmann::json::parse(page.substr(begin + open.size(), end - begin - open.size()));
}

// A data: PNG decoded through a file.
ImageU8 DecodeDataUri(const std::string& uri, const fs::path& scratch) {
  const std::string prefix = "data:image/png;base64,";
  if (uri.rfind(prefix, 0) != 0) return {};
  static const std::string kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::vector<uint8_t> bytes;
  uint32_t bits = 0;
  int count = 0;
  for (char c : uri.substr(prefix.size())) {
    if (c == '=') break;
    bits = (bits << 6) | uint32_t(kAlphabet.find(c));
    count += 6;
    if (count >= 8) {
      count -= 8;
      bytes.push_back(uint8_t(bits >> count));
    }
  }
  WriteFileAtomic(scratch, bytes, OverwritePolicy::kReplace);
  return ReadImageU8(scratch);
}

TEST(PreviewPageTest, SelfContainedPageWithTheMapsAndFiles) {
  TemporaryFolder dir;
  const PreviewPageSummary summary = WriteRidgedPage(dir / "preview.html", RidgedMaps(2048, 1536));
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  EXPECT_EQ(summary.texture_width, 1024);
  EXPECT_EQ(summary.texture_height, 768);
  const std::string page = ReadText(dir / "preview.html");
  EXPECT_EQ(summary.bytes, page.size());
  // Nothing fetched from elsewhere: no external script, stylesheet or image.
  EXPECT_THAT(page, ::testing::Not(HasSubstr("src=\"http")));
  EXPECT_THAT(page, ::testing::Not(HasSubstr("<link")));
  EXPECT_THAT(page, HasSubstr("import('data:text/javascript;base64,' + moduleText)"));
  EXPECT_THAT(page, ::testing::Not(HasSubstr("__SCANBENCH_")));

  const nlohmann::json data = PageData(page);
  ASSERT_TRUE(data.is_object());
  EXPECT_EQ(data["title"], "ridged test sample");
  EXPECT_NEAR(data["width_mm"].get<double>(), 204.8, 1e-9);
  EXPECT_NEAR(data["height_mm"].get<double>(), 153.6, 1e-9);
  ASSERT_EQ(data["files"].size(), 2u);
  EXPECT_EQ(data["files"][0]["path"], "ridged/ridged_normal.png");
  EXPECT_EQ(data["files"][0]["bytes"], 123456);
  std::vector<std::string> labels;
  for (const auto& map : data["maps"]) labels.push_back(map["label"]);
  EXPECT_THAT(labels, ::testing::ElementsAre("base colour", "normal", "roughness", "ambient occlusion", "height",
                                             "solved mask"));

  // The textures: 1024 px on the long side, 8-bit; the base colour through
  // the sRGB curve, normals (n + 1) / 2 with +Y up, roughness sqrt(alpha).
  const nlohmann::json& maps = data["maps"];
  const ImageU8 base = DecodeDataUri(maps[0]["uri"], dir / "base.png");
  ASSERT_TRUE(base.SameSize(1024, 768));
  EXPECT_EQ(base(10, 10, 0), 170);  // srgb(0.4) = 0.665
  const ImageU8 normal = DecodeDataUri(maps[1]["uri"], dir / "normal.png");
  ASSERT_TRUE(normal.SameSize(1024, 768));
  // Row 2 of the texture averages source rows 4 and 5 (sin 90 and 112.5 deg
  // of the ridges, plus the tilt): the normal points up, so green > 128.
  EXPECT_GT(normal(100, 2, 1), 190);  // n_y 0.6: 204
  EXPECT_EQ(normal(100, 2, 0), 128);
  const ImageU8 roughness = DecodeDataUri(maps[2]["uri"], dir / "roughness.png");
  ASSERT_FALSE(roughness.empty());
  EXPECT_EQ(roughness(5, 5, 0), 153);  // sqrt(0.36) * 255
}

TEST(PreviewPageTest, SmallMapsKeepTheirSize) {
  TemporaryFolder dir;
  const PreviewPageSummary summary = WriteRidgedPage(dir / "preview.html", RidgedMaps());
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  EXPECT_EQ(summary.texture_width, kWidth);
  EXPECT_EQ(summary.texture_height, kHeight);
}

TEST(PreviewPageTest, MismatchedMapIsAnErrorNamingIt) {
  TemporaryFolder dir;
  PreviewPageMaps maps = RidgedMaps();
  maps.roughness_alpha = ImageF(10, 10, 1);
  try {
    WriteRidgedPage(dir / "preview.html", maps);
    ADD_FAILURE() << "expected an error";
  } catch (const std::invalid_argument& error) {
    EXPECT_THAT(error.what(), HasSubstr("preview.html: roughness_alpha is 10x10x1, 256x192x1 expected"));
  }
  maps = RidgedMaps();
  EXPECT_THROW(WritePreviewPage({}, maps, 0.0, {}, dir / "preview.html"), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir / "preview.html"));
}

TEST(PreviewPageTest, BadOptionAndExistingFileAreErrors) {
  TemporaryFolder dir;
  PreviewPageOptions options;
  options.max_texture_px = 8;
  EXPECT_THROW(WriteRidgedPage(dir / "preview.html", RidgedMaps(), options), std::invalid_argument);
  WriteFileAtomic(dir / "preview.html", std::string_view("earlier"), OverwritePolicy::kRefuse);
  EXPECT_THROW(WriteRidgedPage(dir / "preview.html", RidgedMaps()), std::runtime_error);
  EXPECT_EQ(ReadText(dir / "preview.html"), "earlier");
}

TEST(PreviewPageTest, CancelWritesNothing) {
  TemporaryFolder dir;
  const PreviewPageSummary summary =
      WritePreviewPage({}, RidgedMaps(), 0.1, {}, dir / "preview.html", [](double fraction) { return fraction < 0.3; });
  EXPECT_TRUE(summary.IsCancelled());
  EXPECT_FALSE(fs::exists(dir / "preview.html"));
}

// The export makes the textures from borrowed maps while it writes its files,
// then the page: the same bytes as in one step. The maps are downsampled
// (1100 x 700 to 1024 x 652), each texture row from its own source rows:
// roughness 0.04 on the even rows (solved), 0.64 on the odd ones (unsolved),
// so a texel reads sqrt(0.04) when one of its rows is even, else the mean of
// all its pixels, sqrt(0.64).
TEST(PreviewPageTest, TwoStepsFromBorrowedMapsWriteTheSamePage) {
  TemporaryFolder dir;
  constexpr int width = 1100, height = 700;
  PreviewPageMaps maps = RidgedMaps(width, height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      maps.roughness_alpha(x, y) = y % 2 == 0 ? 0.04f : 0.64f;
      maps.valid(x, y) = y % 2 == 0;
    }
  }
  const std::vector<PreviewPageFile> files = {{"ridged/ridged_normal.png", 123456}};
  PreviewPageOptions options;
  options.title = "two steps";
  ASSERT_TRUE(WritePreviewPage(options, maps, 0.1, files, dir / "one.html").IsUsable());
  const PreviewPageTextures textures =
      MakePreviewTextures(options, PreviewPageMapViews::Of(maps), 0.1, dir / "two.html");
  ASSERT_TRUE(textures.summary.IsUsable()) << textures.summary.message;
  EXPECT_FALSE(fs::exists(dir / "two.html"));  // the textures alone write nothing
  const PreviewPageSummary two = WritePreviewPage(options, textures, files, dir / "two.html");
  ASSERT_TRUE(two.IsUsable()) << two.message;
  EXPECT_EQ(ReadText(dir / "one.html"), ReadText(dir / "two.html"));

  const nlohmann::json data = PageData(ReadText(dir / "two.html"));
  ASSERT_EQ(data["texture"]["height"], 652);
  const ImageU8 roughness = DecodeDataUri(data["maps"][2]["uri"], dir / "roughness.png");
  ASSERT_EQ(roughness.height(), 652);
  int mixed = 0;
  for (int texel_row = 0; texel_row < roughness.height(); ++texel_row) {
    bool has_even_row = false;
    for (int y = 0; y < height; ++y) has_even_row |= y * 652 / height == texel_row && y % 2 == 0;
    mixed += has_even_row;
    EXPECT_EQ(roughness(7, texel_row, 0), has_even_row ? 51 : 204) << "texel row " << texel_row;
  }
  EXPECT_GT(mixed, 300);
  EXPECT_LT(mixed, 652);
}

TEST(PreviewPageTest, FragmentNamesTheOptions) {
  EXPECT_EQ(PreviewPageFragment(false, 90, 30, false), "#normal=off&light=90,30&panel=off");
  EXPECT_EQ(PreviewPageFragment(true, 120, 40, true), "#light=120,40");
  EXPECT_EQ(PreviewPageFragment(true, 90, 60, false, true), "#light=90,60&panel=off&frame=on");
}

// Issue #36: the sample shown is the tileable crop where the export has one
// (its own maps, not a crop of the frame), else the centred crop.
TEST(PreviewPageTest, SampleIsTheTileableCropWhenThereIsOne) {
  TemporaryFolder dir;
  const PreviewPageMaps maps = RidgedMaps();
  const PreviewPageOptions options;
  PreviewPageTextures centred = MakePreviewTextures(options, maps, 0.1, dir / "a.html");
  ASSERT_TRUE(WritePreviewPage(options, centred, {}, dir / "a.html").IsUsable());
  nlohmann::json data = PageData(ReadText(dir / "a.html"));
  EXPECT_EQ(data["sample"]["tileable"], false);
  EXPECT_EQ(data["sample"]["width_px"], 154);  // 0.6 * 256
  EXPECT_EQ(data["sample"]["height_px"], 115);
  EXPECT_NEAR(data["sample"]["width_mm"].get<double>(), 15.4, 1e-9);

  const ImageF tile_albedo(64, 64, 3, 0.2f), tile_normal(64, 64, 3, 0.0f);
  ImageF tile_up = tile_normal;
  for (size_t i = 0; i < tile_up.num_pixels(); ++i) tile_up.data()[3 * i + 2] = 1;
  const ImageF tile_roughness(64, 64, 1, 0.25f);
  PreviewPageMapViews views = PreviewPageMapViews::Of(maps);
  views.tile_basecolor_linear_rec709 = &tile_albedo;
  views.tile_normal_in_tangent = &tile_up;
  views.tile_roughness_alpha = &tile_roughness;
  const PreviewPageTextures tiled = MakePreviewTextures(options, views, 0.1, dir / "b.html");
  ASSERT_TRUE(WritePreviewPage(options, tiled, {}, dir / "b.html").IsUsable());
  data = PageData(ReadText(dir / "b.html"));
  EXPECT_EQ(data["sample"]["tileable"], true);
  EXPECT_EQ(data["sample"]["width_px"], 64);
  const nlohmann::json& textures = data["maps"];
  const ImageU8 base = DecodeDataUri(textures[0]["sphere_uri"], dir / "base.png");
  ASSERT_TRUE(base.SameSize(64, 64));
  EXPECT_EQ(base(30, 30, 0), 124);  // srgb(0.2), the tile's, not the frame's 0.4
  const ImageU8 roughness = DecodeDataUri(textures[2]["sphere_uri"], dir / "roughness.png");
  EXPECT_EQ(roughness(3, 3, 0), 128);  // sqrt(0.25) * 255
  EXPECT_FALSE(textures[3].contains("sphere_uri")) << "the tile has no occlusion: not the frame's crop instead";
  // The whole frame stays on the page, for #frame=on.
  EXPECT_TRUE(DecodeDataUri(textures[0]["uri"], dir / "frame.png").SameSize(kWidth, kHeight));

  views.tile_normal_in_tangent = &tile_roughness;  // one channel
  try {
    MakePreviewTextures(options, views, 0.1, dir / "c.html");
    ADD_FAILURE() << "expected an error";
  } catch (const std::invalid_argument& error) {
    EXPECT_THAT(error.what(), HasSubstr("c.html: tile_normal_in_tangent is 64x64x1, 64x64x3 expected"));
  }
}

// --- In headless Chromium -----------------------------------------------------

std::string FindChromium() {
  const CommandResult found = RunShell("command -v chromium || command -v chromium-browser");
  if (found.exit_code != 0) return {};
  std::string path = found.output;
  while (!path.empty() && std::isspace(static_cast<unsigned char>(path.back()))) path.pop_back();
  return path;
}

constexpr int kWindowWidth = 1024, kWindowHeight = 512;

// A screenshot of `page` + `fragment` at kWindowWidth x kWindowHeight.
ImageU8 Screenshot(const std::string& chromium, const fs::path& page, const std::string& fragment,
                   const fs::path& png, const fs::path& profile) {
  // SwiftShader renders on the CPU: 6 s a screenshot on an idle machine, over
  // 50 s beside the rest of the suite on two cores (seen once).
  const std::string command =
      "timeout 180 " + Quoted(chromium) +
      " --headless=new --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader --hide-scrollbars"
      " --no-first-run --disable-extensions --force-device-scale-factor=1 --user-data-dir=" + Quoted(profile) +
      " --window-size=" + std::to_string(kWindowWidth) + "," + std::to_string(kWindowHeight) +
      " --virtual-time-budget=10000 --screenshot=" + Quoted(png) + " " + Quoted("file://" + page.string() + fragment);
  const CommandResult result = RunShell(command);
  EXPECT_EQ(result.exit_code, 0) << command << "\n" << result.output;
  if (!fs::exists(png)) {
    ADD_FAILURE() << "no screenshot from " << command << "\n" << result.output;
    return {};
  }
  return ReadImageU8(png);
}

double Luminance(const ImageU8& image, int x, int y) {
  return (image(x, y, 0) + image(x, y, 1) + image(x, y, 2)) / 3.0;
}

struct Box {
  int x0, y0, x1, y1;  // [x0, x1) x [y0, y1)
};

// The central 60 % of the tile (preview_page.h's layout).
Box TileInterior(double sample_aspect) {
  const double tile_w = std::min(0.85 * kWindowWidth / 2, 0.85 * kWindowHeight * sample_aspect);
  const double tile_h = tile_w / sample_aspect;
  const double cx = kWindowWidth / 4.0, cy = kWindowHeight / 2.0;
  return {int(cx - 0.3 * tile_w), int(cy - 0.3 * tile_h), int(cx + 0.3 * tile_w), int(cy + 0.3 * tile_h)};
}

double MeanLuminance(const ImageU8& image, const Box& box) {
  double sum = 0;
  for (int y = box.y0; y < box.y1; ++y) {
    for (int x = box.x0; x < box.x1; ++x) sum += Luminance(image, x, y);
  }
  return sum / ((box.x1 - box.x0) * (box.y1 - box.y0));
}

// Mean squared 4-neighbour Laplacian of the luminance: the high-frequency energy.
double HighFrequencyEnergy(const ImageU8& image, const Box& box) {
  double sum = 0;
  for (int y = box.y0; y < box.y1; ++y) {
    for (int x = box.x0; x < box.x1; ++x) {
      const double laplacian = 4 * Luminance(image, x, y) - Luminance(image, x - 1, y) - Luminance(image, x + 1, y) -
                               Luminance(image, x, y - 1) - Luminance(image, x, y + 1);
      sum += laplacian * laplacian;
    }
  }
  return sum / ((box.x1 - box.x0) * (box.y1 - box.y0));
}

// Mean luminance of the sphere's upper or lower half, inside 80 % of its radius.
double SphereHalfLuminance(const ImageU8& image, bool upper) {
  const double cx = 0.75 * kWindowWidth, cy = kWindowHeight / 2.0;
  const double radius = 0.4 * std::min(kWindowWidth / 2.0, double(kWindowHeight));
  double sum = 0;
  int count = 0;
  for (int y = 0; y < kWindowHeight; ++y) {
    for (int x = kWindowWidth / 2; x < kWindowWidth; ++x) {
      const double dx = x - cx, dy = y - cy;
      if (std::hypot(dx, dy) > 0.8 * radius || std::abs(dy) < 0.1 * radius || (dy < 0) != upper) continue;
      sum += Luminance(image, x, y);
      ++count;
    }
  }
  return count > 0 ? sum / count : 0;
}

TEST(PreviewPageBrowserTest, RendersLitSphereAndNormalDetail) {
  const std::string chromium = FindChromium();
  if (chromium.empty()) {
    GTEST_SKIP() << "chromium is not installed (Debian package `chromium`, scripts/install-deps.sh): "
                    "the preview page's render is not checked";
  }
  TemporaryFolder dir;
  const fs::path page = dir / "preview.html";
  ASSERT_TRUE(WriteRidgedPage(page, RidgedMaps()).IsUsable());
  // Light from the image's top (+y), 30 degrees above the sample.
  const ImageU8 with_normals =
      Screenshot(chromium, page, PreviewPageFragment(true, 90, 30, false), dir / "on.png", dir / "profile");
  const ImageU8 without =
      Screenshot(chromium, page, PreviewPageFragment(false, 90, 30, false), dir / "off.png", dir / "profile");
  ASSERT_TRUE(with_normals.SameSize(kWindowWidth, kWindowHeight)) << ShapeText(with_normals);
  ASSERT_TRUE(without.SameSize(kWindowWidth, kWindowHeight)) << ShapeText(without);

  const Box tile = TileInterior(double(kWidth) / kHeight);
  const double background = Luminance(with_normals, 5, 5);
  const double tile_on = MeanLuminance(with_normals, tile), tile_off = MeanLuminance(without, tile);
  const double upper = SphereHalfLuminance(without, true), lower = SphereHalfLuminance(without, false);
  const double energy_on = HighFrequencyEnergy(with_normals, tile), energy_off = HighFrequencyEnergy(without, tile);
  std::cout << "background " << background << ", tile mean with normal map " << tile_on << ", without " << tile_off
            << "; sphere lit (upper) half " << upper << ", unlit (lower) half " << lower
            << "; tile high-frequency energy with normal map " << energy_on << ", without " << energy_off << "\n";
  // SCANBENCH_KEEP_SCREENSHOTS=DIR keeps the two renders and the page, to look at.
  if (const char* keep = std::getenv("SCANBENCH_KEEP_SCREENSHOTS")) {
    for (const char* name : {"on.png", "off.png", "preview.html"}) {
      fs::copy_file(dir / name, fs::path(keep) / (std::string("preview_page_test_") + name),
                    fs::copy_options::overwrite_existing);
    }
  }
  // Not blank: the tile and the sphere stand out from the background.
  EXPECT_GT(tile_off, background + 30);
  EXPECT_GT(upper, background + 30);
  // Brighter on the lit side.
  EXPECT_GT(upper, 1.5 * lower);
  // The ridges are there, and tilted towards the light (+Y up read as up).
  EXPECT_GT(energy_on, 10 * energy_off + 1);
  EXPECT_GT(tile_on, tile_off + 10);
}

// Issue #36: the sample on the dome has no seam. The frame's albedo runs from
// dark at the top to light at the bottom inside a red border (the table), so
// a crop repeated on a sphere would show a hard edge where its bottom meets
// its top; the dome shows the centred crop once. The tile shows that crop
// too (no red); with #frame=on it shows the whole frame, border and all.
TEST(PreviewPageBrowserTest, DomeShowsTheSampleWithoutSeamsAndTheFrameOnlyOnRequest) {
  const std::string chromium = FindChromium();
  if (chromium.empty()) GTEST_SKIP() << "chromium is not installed (Debian package `chromium`)";
  TemporaryFolder dir;
  PreviewPageMaps maps = RidgedMaps();
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const bool border = x < kWidth / 10 || x >= kWidth - kWidth / 10 || y < kHeight / 10 || y >= kHeight - kHeight / 10;
      const float grey = 0.03f + 0.6f * float(y) / (kHeight - 1);
      for (int c = 0; c < 3; ++c) maps.basecolor_linear_rec709(x, y, c) = border ? (c == 0 ? 0.6f : 0.02f) : grey;
      maps.normal_in_tangent(x, y, 0) = maps.normal_in_tangent(x, y, 1) = 0;
      maps.normal_in_tangent(x, y, 2) = 1;
    }
  }
  const fs::path page = dir / "preview.html";
  ASSERT_TRUE(WriteRidgedPage(page, maps).IsUsable());
  const ImageU8 sample = Screenshot(chromium, page, PreviewPageFragment(true, 90, 70, false), dir / "s.png", dir / "p");
  const ImageU8 frame =
      Screenshot(chromium, page, PreviewPageFragment(true, 90, 70, false, true), dir / "f.png", dir / "p");
  ASSERT_TRUE(sample.SameSize(kWindowWidth, kWindowHeight) && frame.SameSize(kWindowWidth, kWindowHeight));
  if (const char* keep = std::getenv("SCANBENCH_KEEP_SCREENSHOTS")) {
    for (const char* name : {"s.png", "f.png"}) {
      fs::copy_file(dir / name, fs::path(keep) / (std::string("preview_page_test_seams_") + name),
                    fs::copy_options::overwrite_existing);
    }
  }
  // The dome: the largest step in luminance between neighbouring pixels inside 90 % of its outline.
  const double cx = 0.75 * kWindowWidth, cy = kWindowHeight / 2.0;
  const double radius = 0.4 * std::min(kWindowWidth / 2.0, double(kWindowHeight));
  double worst_step = 0, dome_sum = 0;
  int dome_pixels = 0;
  for (int y = 1; y < kWindowHeight; ++y) {
    for (int x = kWindowWidth / 2 + 1; x < kWindowWidth; ++x) {
      if (std::hypot(x - cx, y - cy) > 0.9 * radius) continue;
      worst_step = std::max({worst_step, std::abs(Luminance(sample, x, y) - Luminance(sample, x, y - 1)),
                             std::abs(Luminance(sample, x, y) - Luminance(sample, x - 1, y))});
      dome_sum += Luminance(sample, x, y);
      ++dome_pixels;
    }
  }
  // Red: the border's colour, red well above green.
  auto red_pixels = [](const ImageU8& image, int x0, int x1) {
    int count = 0;
    for (int y = 0; y < kWindowHeight; ++y)
      for (int x = x0; x < x1; ++x) count += image(x, y, 0) > image(x, y, 1) + 60;
    return count;
  };
  const int tile_red = red_pixels(sample, 0, kWindowWidth / 2), frame_red = red_pixels(frame, 0, kWindowWidth / 2);
  const int dome_red = red_pixels(sample, kWindowWidth / 2, kWindowWidth);
  std::cout << "dome: mean luminance " << dome_sum / std::max(1, dome_pixels) << ", largest neighbour step "
            << worst_step << "; red pixels: tile " << tile_red << " (frame=on " << frame_red << "), dome " << dome_red
            << "\n";
  EXPECT_GT(dome_sum / std::max(1, dome_pixels), Luminance(sample, 5, 5) + 20) << "the dome is drawn";
  EXPECT_LT(worst_step, 12) << "a seam on the dome";
  EXPECT_EQ(tile_red, 0) << "the tile shows the sample, not the table around it";
  EXPECT_EQ(dome_red, 0);
  EXPECT_GT(frame_red, 1000) << "#frame=on shows the whole frame";
}

// Any export's page, e.g. the demo's: SCANBENCH_PREVIEW_PAGE=/path/preview.html.
// The same measures as above, printed; only not blank and brighter on the lit
// side are asserted (a real material's albedo has high frequencies of its own).
TEST(PreviewPageBrowserTest, RendersAGivenPage) {
  const char* given = std::getenv("SCANBENCH_PREVIEW_PAGE");
  if (given == nullptr) GTEST_SKIP() << "set SCANBENCH_PREVIEW_PAGE=/path/preview.html to measure an export's page";
  const std::string chromium = FindChromium();
  if (chromium.empty()) GTEST_SKIP() << "chromium is not installed (Debian package `chromium`)";
  const fs::path page = fs::absolute(given);
  const nlohmann::json data = PageData(ReadText(page));
  ASSERT_TRUE(data.is_object()) << page << ": no scanbench-data block";
  TemporaryFolder dir;
  const ImageU8 with_normals =
      Screenshot(chromium, page, PreviewPageFragment(true, 90, 30, false), dir / "on.png", dir / "profile");
  const ImageU8 without =
      Screenshot(chromium, page, PreviewPageFragment(false, 90, 30, false), dir / "off.png", dir / "profile");
  ASSERT_TRUE(with_normals.SameSize(kWindowWidth, kWindowHeight) && without.SameSize(kWindowWidth, kWindowHeight));
  const Box tile = TileInterior(data["sample"]["width_mm"].get<double>() / data["sample"]["height_mm"].get<double>());
  const double background = Luminance(with_normals, 5, 5);
  const double upper = SphereHalfLuminance(with_normals, true), lower = SphereHalfLuminance(with_normals, false);
  std::cout << page.string() << ": background " << background << ", tile mean with normal map "
            << MeanLuminance(with_normals, tile) << ", without " << MeanLuminance(without, tile)
            << "; sphere lit (upper) half " << upper << ", unlit (lower) half " << lower
            << "; tile high-frequency energy with normal map " << HighFrequencyEnergy(with_normals, tile)
            << ", without " << HighFrequencyEnergy(without, tile) << "\n";
  EXPECT_GT(MeanLuminance(with_normals, tile), background + 30);
  EXPECT_GT(upper, 1.5 * lower);
}

}  // namespace
}  // namespace scanbench
