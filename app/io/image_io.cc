#include "app/io/image_io.h"

#include <OpenImageIO/filesystem.h>
#include <Imath/half.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <memory>
#include <mutex>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <system_error>
#if defined(__x86_64__)
#include <immintrin.h>
#include <cpuid.h>
#endif

namespace scanbench {
namespace fs = std::filesystem;

namespace {

std::runtime_error PathError(const fs::path& path, const std::string& problem) {
  return std::runtime_error(path.string() + ": " + problem);
}

std::string OiioMessage(const std::string& message) {
  return message.empty() ? "OpenImageIO gave no reason" : "OpenImageIO: " + message;
}

template <typename T>
void CheckWritable(const fs::path& path, const Image<T>& image, const char* format, int max_channels) {
  if (image.empty()) {
    throw std::invalid_argument(path.string() + ": cannot write an empty " + std::to_string(image.width()) + "x" +
                                std::to_string(image.height()) + "x" + std::to_string(image.channels()) +
                                " image as " + format);
  }
  if (max_channels > 0 && image.channels() > max_channels) {
    throw std::invalid_argument(path.string() + ": " + format + " holds at most " + std::to_string(max_channels) +
                                " channels, the image has " + std::to_string(image.channels()));
  }
}

// Writes `pixels` to a temporary sibling with the writer for `format` (the
// temporary name has no image extension), then commits it under `policy`.
// `write_pixels` writes the pixels into the opened output (the whole image,
// or scanlines band by band) and says whether it succeeded.
void WriteAtomicallyWith(const fs::path& path, const char* format, const OIIO::ImageSpec& spec,
                         OverwritePolicy policy, const std::function<bool(OIIO::ImageOutput&)>& write_pixels) {
  // Fail before encoding anything; CommitTemporaryFile re-checks atomically.
  if (policy == OverwritePolicy::kRefuse && fs::exists(path)) {
    throw PathError(path, "already exists and is never overwritten");
  }
  const fs::path temporary = TemporarySiblingPath(path);
  auto discard = [&temporary] {
    std::error_code ignored;
    fs::remove(temporary, ignored);
  };
  std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(format);
  if (!out) throw PathError(path, std::string("no ") + format + " writer (" + OiioMessage(OIIO::geterror()) + ")");
  if (!out->open(temporary.string(), spec)) {
    const std::string message = out->geterror();
    discard();
    throw PathError(path, std::string("cannot be written as ") + format + " (" + OiioMessage(message) + ")");
  }
  const bool written = write_pixels(*out);
  const bool closed = out->close();
  if (!written || !closed) {
    const std::string message = out->geterror();
    discard();
    throw PathError(path, std::string("writing ") + format + " failed (" + OiioMessage(message) + ")");
  }
  out.reset();
  CommitTemporaryFile(temporary, path, policy);
}

void WriteAtomically(const fs::path& path, const char* format, const OIIO::ImageSpec& spec, const void* pixels,
                     OverwritePolicy policy) {
  WriteAtomicallyWith(path, format, spec, policy,
                      [&](OIIO::ImageOutput& out) { return out.write_image(spec.format, pixels); });
}

template <typename T>
OIIO::ImageSpec SpecFor(const Image<T>& image, OIIO::TypeDesc type) {
  OIIO::ImageSpec spec(image.width(), image.height(), image.channels(), type);
  // Store alpha as given: OpenImageIO would otherwise (un)premultiply.
  spec.attribute("oiio:UnassociatedAlpha", 1);
  return spec;
}

std::vector<std::string> DefaultChannelNames(int channels) {
  switch (channels) {
    case 1: return {"Y"};
    case 2: return {"Y", "A"};
    case 3: return {"R", "G", "B"};
    case 4: return {"R", "G", "B", "A"};
    default: return {};  // OpenImageIO's defaults
  }
}

enum class FileFormat { kExr, kPng, kTiff };

std::string FormatNumber(double value, int digits = 9) {
  char text[40];
  std::snprintf(text, sizeof(text), "%.*g", digits, value);
  return text;
}

std::array<double, 8> ChromaticityValues(const ImageChromaticities& c) {
  return {c.red_x, c.red_y, c.green_x, c.green_y, c.blue_x, c.blue_y, c.white_x, c.white_y};
}

ImageChromaticities ChromaticitiesFrom(const std::array<double, 8>& v) {
  return {v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]};
}

constexpr const char* kChromaticityNames[8] = {"red_x",  "red_y",  "green_x", "green_y",
                                               "blue_x", "blue_y", "white_x", "white_y"};
constexpr const char* kChromaticitiesAttribute = "scanbench:chromaticities";

void CheckChromaticities(const fs::path& path, const ImageChromaticities& chromaticities) {
  const std::array<double, 8> values = ChromaticityValues(chromaticities);
  for (int i = 0; i < 8; ++i) {
    if (!std::isfinite(values[i])) {
      throw std::invalid_argument(path.string() + ": ImageMetadata.chromaticities." + kChromaticityNames[i] + " = " +
                                  FormatNumber(values[i]) + " must be finite");
    }
  }
  if (chromaticities.white_y <= 0) {
    throw std::invalid_argument(path.string() + ": ImageMetadata.chromaticities.white_y = " +
                                FormatNumber(chromaticities.white_y) + " must be > 0 (Y of the white is 1)");
  }
}

std::string ChromaticitiesText(const ImageChromaticities& chromaticities) {
  std::string text;
  for (double value : ChromaticityValues(chromaticities)) {
    if (!text.empty()) text += ' ';
    text += FormatNumber(value, 17);
  }
  return text;
}

std::optional<ImageChromaticities> ParseChromaticities(const std::string& text) {
  std::istringstream stream(text);
  std::array<double, 8> values{};
  for (double& value : values) {
    if (!(stream >> value) || !std::isfinite(value)) return std::nullopt;
  }
  std::string rest;
  if (stream >> rest) return std::nullopt;
  return ChromaticitiesFrom(values);
}

void CheckMetadata(const fs::path& path, const ImageMetadata& metadata) {
  if (!std::isfinite(metadata.mm_per_pixel) || metadata.mm_per_pixel < 0) {
    throw std::invalid_argument(path.string() + ": ImageMetadata.mm_per_pixel = " + FormatNumber(metadata.mm_per_pixel) +
                                " must be finite and >= 0");
  }
  if (metadata.chromaticities) CheckChromaticities(path, *metadata.chromaticities);
  static const std::regex kName("scanbench:[A-Za-z0-9_.]+");
  for (const auto& [name, value] : metadata.attributes) {
    if (!std::regex_match(name, kName)) {
      throw std::invalid_argument(path.string() + ": ImageMetadata.attributes name '" + name +
                                  "' must be scanbench:[A-Za-z0-9_.]+");
    }
    if (value.find_first_of("\r\n") != std::string::npos) {
      throw std::invalid_argument(path.string() + ": ImageMetadata.attributes[" + name + "] must be one line");
    }
  }
}

void AddMetadata(const fs::path& path, const ImageMetadata& metadata, FileFormat format, OIIO::ImageSpec& spec) {
  CheckMetadata(path, metadata);
  spec.attribute("Software", "scanbench " SCANBENCH_VERSION);
  std::map<std::string, std::string> attributes = metadata.attributes;
  if (metadata.mm_per_pixel > 0) {
    // EXR stores pixels per inch; OpenImageIO 2.4 divides instead of
    // multiplying when handed "cm" for EXR, so EXR is given inches directly.
    const bool inch = format == FileFormat::kExr;
    const float pixels_per_unit = static_cast<float>((inch ? 25.4 : 10.0) / metadata.mm_per_pixel);
    spec.attribute("XResolution", pixels_per_unit);
    spec.attribute("YResolution", pixels_per_unit);
    spec.attribute("ResolutionUnit", inch ? "in" : "cm");
    attributes["scanbench:mm_per_pixel"] = FormatNumber(metadata.mm_per_pixel, 17);  // round-trips exactly
  }
  if (!metadata.color_space.empty()) {
    spec.attribute("oiio:ColorSpace", metadata.color_space);
    attributes["scanbench:color_space"] = metadata.color_space;
  }
  if (metadata.chromaticities) {
    if (format == FileFormat::kExr) {
      // OpenImageIO turns exactly this (FLOAT[8], rx ry gx gy bx by wx wy) into
      // OpenEXR's standard chromaticities attribute.
      std::array<float, 8> values{};
      const std::array<double, 8> exact = ChromaticityValues(*metadata.chromaticities);
      for (int i = 0; i < 8; ++i) values[i] = static_cast<float>(exact[i]);
      spec.attribute("chromaticities", OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8), values.data());
    }
    attributes[kChromaticitiesAttribute] = ChromaticitiesText(*metadata.chromaticities);
  }
  std::string description = metadata.description;
  for (const auto& [name, value] : attributes) {
    if (format == FileFormat::kTiff) {
      description += (description.empty() ? "" : "\n") + name + "=" + value;
    } else {
      spec.attribute(name, value);
    }
  }
  if (!description.empty()) spec.attribute("ImageDescription", description);
}

struct OpenedInput {
  std::unique_ptr<OIIO::ImageInput> input;
  OIIO::ImageSpec spec;
};

// OpenImageIO picks its OpenEXR reader (the default one or the one on the
// OpenEXR core library) from the process-wide "openexr:core" when a reader is
// created, so every reader is created under this lock: the one that asks for
// the core reader sets the attribute and restores it before the lock is let go.
std::mutex& ReaderChoiceMutex() {
  static std::mutex mutex;
  return mutex;
}

// The OpenEXR core library's reader of `path`, opened; null when there is
// none or it cannot open the file (the caller then uses the default reader).
std::unique_ptr<OIIO::ImageInput> OpenExrCoreInput(const fs::path& path, const OIIO::ImageSpec& config) {
  std::unique_ptr<OIIO::ImageInput> input;
  {
    const std::lock_guard<std::mutex> lock(ReaderChoiceMutex());
    int before = 0;
    OIIO::getattribute("openexr:core", before);
    OIIO::attribute("openexr:core", 1);
    input = OIIO::ImageInput::create("openexr", /*do_open=*/false);
    OIIO::attribute("openexr:core", before);
  }
  OIIO::ImageSpec spec;
  if (!input || !input->open(path.string(), spec, config)) {
    if (input) input->geterror();  // cleared: the default reader says why, if it fails too
    OIIO::geterror();
    return nullptr;
  }
  return input;
}

// `openexr_core`: an .exr file through the core library's reader when it opens it.
OpenedInput OpenInput(const fs::path& path, bool openexr_core = false) {
  if (!fs::exists(path)) throw PathError(path, "does not exist");
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  OpenedInput opened;
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (openexr_core && extension == ".exr") opened.input = OpenExrCoreInput(path, config);
  if (!opened.input) {
    // Only the reader the extension names: when it refuses the file,
    // ImageInput::open would try every reader OpenImageIO has (DICOM, FITS,
    // RAW, ...), seconds and gigabytes on a corrupt .exr (found by fuzzing the
    // export's map reader). An extension no reader claims still gets them all.
    std::string message;
    {
      const std::lock_guard<std::mutex> lock(ReaderChoiceMutex());
      opened.input = OIIO::ImageInput::create(path.string(), /*do_open=*/false);
    }
    if (opened.input) {
      OIIO::ImageSpec spec;
      if (!opened.input->open(path.string(), spec, config)) {
        message = opened.input->geterror();
        opened.input.reset();
      }
    } else {
      message = OIIO::geterror();
    }
    if (!opened.input) throw PathError(path, "cannot be read as an image (" + OiioMessage(message) + ")");
  }
  opened.spec = opened.input->spec();
  if (opened.spec.width <= 0 || opened.spec.height <= 0 || opened.spec.nchannels <= 0 ||
      opened.spec.depth > 1) {
    throw PathError(path, "has an unsupported size " + std::to_string(opened.spec.width) + "x" +
                              std::to_string(opened.spec.height) + "x" + std::to_string(opened.spec.depth) +
                              " with " + std::to_string(opened.spec.nchannels) + " channels");
  }
  return opened;
}

template <typename T>
Image<T> ReadPixels(const fs::path& path, OpenedInput& opened, OIIO::TypeDesc type) {
  const OIIO::ImageSpec& spec = opened.spec;
  Image<T> image(spec.width, spec.height, spec.nchannels);
  if (!opened.input->read_image(0, 0, 0, spec.nchannels, type, image.data())) {
    throw PathError(path, "cannot read its pixels (" + OiioMessage(opened.input->geterror()) + ")");
  }
  return image;
}

void RequireInteger(const fs::path& path, const OIIO::ImageSpec& spec, int max_bits, const char* reader) {
  const OIIO::TypeDesc format = spec.format;
  const bool integer = format == OIIO::TypeDesc::UINT8 || format == OIIO::TypeDesc::UINT16;
  if (!integer || static_cast<int>(format.size()) * 8 > max_bits) {
    throw PathError(path, std::string("holds ") + format.c_str() + " samples; " + reader +
                              " reads only unsigned integer files of at most " + std::to_string(max_bits) +
                              " bits (use ReadImageFloat)");
  }
}

constexpr float kHalfMax = 65504.0f;  // the largest finite half

// OpenImageIO's png:filter: libpng's PNG_FILTER_* bits; 0 leaves libpng's
// own choice (all five filters, adaptively per row).
int PngFilterBits(PngFilter filter) {
  switch (filter) {
    case PngFilter::kAdaptive: return 0;
    case PngFilter::kNone: return 8;
    case PngFilter::kSub: return 16;
    case PngFilter::kUp: return 32;
    case PngFilter::kAverage: return 64;
    case PngFilter::kPaeth: return 128;
  }
  return 0;
}

void AddPngEncoding(const PngEncoding& encoding, OIIO::ImageSpec& spec) {
  encoding.Check();
  spec.attribute("png:compressionLevel", encoding.zlib_level);
  if (const int bits = PngFilterBits(encoding.filter); bits != 0) spec.attribute("png:filter", bits);
  // OpenImageIO 2.4's PNG writer reads "compression" as the zlib strategy
  // ("default", "filtered", "huffman", "rle", "fixed").
  if (encoding.strategy != PngStrategy::kDefault) spec.attribute("compression", PngStrategyName(encoding.strategy));
}

// PNG (up to 4 channels, as `png_encoding` says) or TIFF (any channel count,
// zip), in the sample type given.
template <typename T>
void WritePngOrTiff(const fs::path& path, const Image<T>& image, OIIO::TypeDesc type, FileFormat format,
                    OverwritePolicy policy, const ImageMetadata& metadata, const PngEncoding& png_encoding = {}) {
  const bool png = format == FileFormat::kPng;
  CheckWritable(path, image, png ? "PNG" : "TIFF", png ? 4 : 0);
  OIIO::ImageSpec spec = SpecFor(image, type);
  if (png) {
    AddPngEncoding(png_encoding, spec);
  } else {
    spec.attribute("compression", "zip");
  }
  AddMetadata(path, metadata, format, spec);
  WriteAtomically(path, png ? "png" : "tiff", spec, image.data(), policy);
}

}  // namespace

namespace {

// WriteExr's checks and OpenEXR spec (float samples in memory; the file's
// sample type is set by ExrSamples' caller).
OIIO::ImageSpec ExrSpec(const fs::path& path, int width, int height, int channels,
                        const std::vector<std::string>& channel_names, const ImageMetadata& metadata,
                        const ExrEncoding& encoding) {
  if (encoding.compression == ExrCompression::kPxr24 && encoding.sample_type == ExrSampleType::kFloat32) {
    throw std::invalid_argument(path.string() + ": ExrEncoding.compression = pxr24 is lossy on float32 samples; "
                                "use it with half only");
  }
  if (encoding.half_absolute_step != 0) {
    int exponent = 0;
    const bool power_of_two = std::isfinite(encoding.half_absolute_step) &&
                              std::frexp(encoding.half_absolute_step, &exponent) == 0.5 && exponent >= -23 &&
                              exponent <= 1;
    if (!power_of_two || encoding.sample_type != ExrSampleType::kHalf) {
      throw std::invalid_argument(path.string() + ": ExrEncoding.half_absolute_step = " +
                                  FormatNumber(encoding.half_absolute_step) +
                                  " must be 0 or a power of two in [2^-24, 1], with half samples");
    }
  }
  if (!channel_names.empty() && static_cast<int>(channel_names.size()) != channels) {
    throw std::invalid_argument(path.string() + ": " + std::to_string(channel_names.size()) +
                                " channel names given for an image with " + std::to_string(channels) +
                                " channels");
  }
  OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::FLOAT);
  // Store alpha as given: OpenImageIO would otherwise (un)premultiply.
  spec.attribute("oiio:UnassociatedAlpha", 1);
  const std::vector<std::string> names = channel_names.empty() ? DefaultChannelNames(channels) : channel_names;
  if (!names.empty()) {
    spec.channelnames = names;
    spec.alpha_channel = -1;
    for (int c = 0; c < channels; ++c) {
      if (names[c] == "A") spec.alpha_channel = c;
    }
  }
  spec.attribute("compression", ExrCompressionName(encoding.compression));
  AddMetadata(path, metadata, FileFormat::kExr, spec);
  if (encoding.sample_type == ExrSampleType::kHalf) spec.set_format(OIIO::TypeDesc::HALF);
  return spec;
}

// `count` float values as half samples: converted (round to nearest) here,
// clamped to half's finite range (a conversion of an out-of-range value would
// give an infinity), small values on encoding.half_absolute_step's grid.
#if defined(__x86_64__)
// HalfSamples' values eight at a time with AVX and F16C, the same bits: the
// grid's division, rounding to nearest (even) and product are the scalar
// ones, NaN passes the clamp as in std::clamp (max/min return their second
// operand when one is NaN), and F16C's conversion to nearest even is the one
// Imath::half takes itself when built for F16C. Returns the values done (a
// multiple of 8); the caller converts the rest.
__attribute__((target("avx,f16c"))) size_t HalfSamplesF16c(const float* values, size_t count, float step,
                                                            uint16_t* out) {
  const __m256 low = _mm256_set1_ps(-kHalfMax), high = _mm256_set1_ps(kHalfMax);
  const __m256 step8 = _mm256_set1_ps(step), limit8 = _mm256_set1_ps(1024 * step);
  const __m256 sign = _mm256_set1_ps(-0.0f);
  size_t i = 0;
  for (; i + 8 <= count; i += 8) {
    const __m256 v = _mm256_loadu_ps(values + i);
    __m256 h = _mm256_min_ps(high, _mm256_max_ps(low, v));
    if (step != 0) {
      const __m256 on_grid = _mm256_mul_ps(
          _mm256_round_ps(_mm256_div_ps(v, step8), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC), step8);
      const __m256 small = _mm256_cmp_ps(_mm256_andnot_ps(sign, v), limit8, _CMP_LT_OQ);
      h = _mm256_blendv_ps(h, on_grid, small);
    }
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + i),
                     _mm256_cvtps_ph(h, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC));
  }
  return i;
}

bool HasF16c() {
  // F16C is CPUID leaf 1's ECX bit 29, read directly: clang 14's
  // __builtin_cpu_supports does not know "f16c" (the fuzz build is clang's).
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  static const bool has =
      __builtin_cpu_supports("avx") && __get_cpuid(1, &eax, &ebx, &ecx, &edx) != 0 && (ecx & bit_F16C) != 0;
  return has;
}
#endif

// Into `out` (count samples; nothing else is written there, so a buffer kept
// from band to band needs no clearing).
void HalfSamples(const float* values, size_t count, const ExrEncoding& encoding, Imath::half* out) {
  size_t done = 0;
#if defined(__x86_64__)
  static_assert(sizeof(Imath::half) == sizeof(uint16_t));
  if (HasF16c()) {
    done = HalfSamplesF16c(values, count, static_cast<float>(encoding.half_absolute_step),
                           reinterpret_cast<uint16_t*>(out));
  }
#endif
  if (encoding.half_absolute_step == 0) {
    for (size_t i = done; i < count; ++i) out[i] = Imath::half(std::clamp(values[i], -kHalfMax, kHalfMax));
  } else {
    // Below 1024 steps the grid's multiples are exact halves (11-bit
    // significand), so the one rounding here is the only one.
    const float step = static_cast<float>(encoding.half_absolute_step), limit = 1024 * step;
    for (size_t i = done; i < count; ++i) {
      const float v = values[i];
      out[i] = Imath::half(std::abs(v) < limit ? std::nearbyint(v / step) * step : std::clamp(v, -kHalfMax, kHalfMax));
    }
  }
}

// A buffer of half samples that keeps its memory: new[] leaves them
// uninitialised (HalfSamples writes every one), unlike a std::vector's zero fill.
class HalfBuffer {
 public:
  Imath::half* Get(size_t count) {
    if (count > capacity_) {
      data_.reset(new Imath::half[count]);
      capacity_ = count;
    }
    return data_.get();
  }

 private:
  std::unique_ptr<Imath::half[]> data_;
  size_t capacity_ = 0;
};

}  // namespace

void WriteExr(const fs::path& path, const ImageF& image, OverwritePolicy policy,
              const std::vector<std::string>& channel_names, const ImageMetadata& metadata,
              const ExrEncoding& encoding) {
  CheckWritable(path, image, "OpenEXR", 0);
  const OIIO::ImageSpec spec =
      ExrSpec(path, image.width(), image.height(), image.channels(), channel_names, metadata, encoding);
  if (encoding.sample_type == ExrSampleType::kFloat32) {
    WriteAtomically(path, "openexr", spec, image.data(), policy);
    return;
  }
  // Half the memory of a float copy.
  HalfBuffer halves;
  Imath::half* samples = halves.Get(image.size());
  HalfSamples(image.data(), image.size(), encoding, samples);
  WriteAtomically(path, "openexr", spec, samples, policy);
}

const char* ExrCompressionName(ExrCompression compression) {
  switch (compression) {
    case ExrCompression::kNone: return "none";
    case ExrCompression::kRle: return "rle";
    case ExrCompression::kZips: return "zips";
    case ExrCompression::kZip: return "zip";
    case ExrCompression::kPiz: return "piz";
    case ExrCompression::kPxr24: return "pxr24";
  }
  return "zip";
}

const char* PngFilterName(PngFilter filter) {
  switch (filter) {
    case PngFilter::kAdaptive: return "adaptive";
    case PngFilter::kNone: return "none";
    case PngFilter::kSub: return "sub";
    case PngFilter::kUp: return "up";
    case PngFilter::kAverage: return "average";
    case PngFilter::kPaeth: return "paeth";
  }
  return "adaptive";
}

const char* PngStrategyName(PngStrategy strategy) {
  switch (strategy) {
    case PngStrategy::kDefault: return "default";
    case PngStrategy::kFiltered: return "filtered";
    case PngStrategy::kHuffmanOnly: return "huffman";
    case PngStrategy::kRle: return "rle";
    case PngStrategy::kFixed: return "fixed";
  }
  return "default";
}

void PngEncoding::Check() const {
  if (zlib_level < 0 || zlib_level > 9) {
    throw std::invalid_argument("PngEncoding.zlib_level = " + std::to_string(zlib_level) + " must be in [0, 9]");
  }
}

void WritePng(const fs::path& path, const ImageU16& image, OverwritePolicy policy, const ImageMetadata& metadata,
              const PngEncoding& encoding) {
  WritePngOrTiff(path, image, OIIO::TypeDesc::UINT16, FileFormat::kPng, policy, metadata, encoding);
}

void WritePng(const fs::path& path, const ImageU8& image, OverwritePolicy policy, const ImageMetadata& metadata,
              const PngEncoding& encoding) {
  WritePngOrTiff(path, image, OIIO::TypeDesc::UINT8, FileFormat::kPng, policy, metadata, encoding);
}

std::vector<uint8_t> EncodePngInMemory(const ImageU8& image) {
  const fs::path name = "(in-memory PNG)";
  CheckWritable(name, image, "PNG", 4);
  OIIO::ImageSpec spec = SpecFor(image, OIIO::TypeDesc::UINT8);
  AddPngEncoding(PngEncoding{}, spec);
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput proxy(bytes);
  std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create("png");
  if (!out) throw PathError(name, "no PNG writer (" + OiioMessage(OIIO::geterror()) + ")");
  if (!out->set_ioproxy(&proxy) || !out->open("memory.png", spec) || !out->write_image(spec.format, image.data()) ||
      !out->close()) {
    throw PathError(name, "encoding failed (" + OiioMessage(out->geterror()) + ")");
  }
  return std::vector<uint8_t>(bytes.begin(), bytes.end());
}

void WritePngRows(const fs::path& path, const PngRowSource& rows, OverwritePolicy policy,
                  const ImageMetadata& metadata, const PngEncoding& encoding) {
  if (rows.width <= 0 || rows.height <= 0 || rows.channels < 1 || rows.channels > 4 ||
      (rows.bits != 8 && rows.bits != 16) || !rows.fill) {
    throw std::invalid_argument(path.string() + ": cannot write a " + std::to_string(rows.width) + "x" +
                                std::to_string(rows.height) + "x" + std::to_string(rows.channels) + " " +
                                std::to_string(rows.bits) + "-bit PNG" + (rows.fill ? "" : " without a row source") +
                                " (1 to 4 channels of 8 or 16 bits)");
  }
  OIIO::ImageSpec spec(rows.width, rows.height, rows.channels,
                       rows.bits == 16 ? OIIO::TypeDesc::UINT16 : OIIO::TypeDesc::UINT8);
  spec.attribute("oiio:UnassociatedAlpha", 1);  // as SpecFor: alpha stored as given
  AddPngEncoding(encoding, spec);
  AddMetadata(path, metadata, FileFormat::kPng, spec);
  // A band of rows at a time: the encoder never sees a whole copy of the image.
  constexpr int kBandRows = 64;
  const size_t row_bytes = static_cast<size_t>(rows.width) * rows.channels * (rows.bits / 8);
  WriteAtomicallyWith(path, "png", spec, policy, [&](OIIO::ImageOutput& out) {
    std::vector<uint8_t> band(row_bytes * kBandRows);
    for (int y_begin = 0; y_begin < rows.height; y_begin += kBandRows) {
      const int y_end = std::min(rows.height, y_begin + kBandRows);
      for (int y = y_begin; y < y_end; ++y) rows.fill(y, band.data() + (y - y_begin) * row_bytes);
      if (!out.write_scanlines(y_begin, y_end, 0, spec.format, band.data())) return false;
    }
    return true;
  });
}

void WriteTiff(const fs::path& path, const ImageU16& image, OverwritePolicy policy, const ImageMetadata& metadata) {
  WritePngOrTiff(path, image, OIIO::TypeDesc::UINT16, FileFormat::kTiff, policy, metadata);
}

void WriteTiff(const fs::path& path, const ImageF& image, OverwritePolicy policy, const ImageMetadata& metadata) {
  WritePngOrTiff(path, image, OIIO::TypeDesc::FLOAT, FileFormat::kTiff, policy, metadata);
}

ImageF ReadImageFloat(const fs::path& path, std::vector<std::string>* channel_names) {
  OpenedInput opened = OpenInput(path);
  ImageF image = ReadPixels<float>(path, opened, OIIO::TypeDesc::FLOAT);
  if (channel_names) *channel_names = opened.spec.channelnames;
  return image;
}

ImageF ReadImageFloatRows(const fs::path& path, int y_begin, int y_end) {
  OpenedInput opened = OpenInput(path);
  const OIIO::ImageSpec& spec = opened.spec;
  if (!(0 <= y_begin && y_begin < y_end && y_end <= spec.height)) {
    throw std::invalid_argument(path.string() + ": rows [" + std::to_string(y_begin) + ", " + std::to_string(y_end) +
                                ") must lie within its " + std::to_string(spec.height) + " rows and not be empty");
  }
  ImageF rows(spec.width, y_end - y_begin, spec.nchannels);
  if (!opened.input->read_scanlines(0, 0, spec.y + y_begin, spec.y + y_end, 0, 0, spec.nchannels,
                                    OIIO::TypeDesc::FLOAT, rows.data())) {
    throw PathError(path, "cannot read rows " + std::to_string(y_begin) + " to " + std::to_string(y_end) + " (" +
                              OiioMessage(opened.input->geterror()) + ")");
  }
  return rows;
}

struct ImageRowReader::State {
  fs::path path;
  OpenedInput opened;
  bool native_float = false;  // every channel stored as float: read as stored
};

ImageRowReader::ImageRowReader(const fs::path& path) : state_(std::make_unique<State>()) {
  state_->path = path;
  state_->opened = OpenInput(path, /*openexr_core=*/true);
  const OIIO::ImageSpec& spec = state_->opened.spec;
  state_->native_float = spec.format == OIIO::TypeDesc::FLOAT &&
                         std::all_of(spec.channelformats.begin(), spec.channelformats.end(),
                                     [](const OIIO::TypeDesc& t) { return t == OIIO::TypeDesc::FLOAT; });
}

ImageRowReader::ImageRowReader(ImageRowReader&&) noexcept = default;
ImageRowReader& ImageRowReader::operator=(ImageRowReader&&) noexcept = default;
ImageRowReader::~ImageRowReader() = default;

const fs::path& ImageRowReader::path() const { return state_->path; }
int ImageRowReader::width() const { return state_->opened.spec.width; }
int ImageRowReader::height() const { return state_->opened.spec.height; }
int ImageRowReader::channels() const { return state_->opened.spec.nchannels; }

void ImageRowReader::ReadRows(int y_begin, int y_end, ImageF* rows) {
  const OIIO::ImageSpec& spec = state_->opened.spec;
  const fs::path& path = state_->path;
  if (!(0 <= y_begin && y_begin < y_end && y_end <= spec.height)) {
    throw std::invalid_argument(path.string() + ": rows [" + std::to_string(y_begin) + ", " + std::to_string(y_end) +
                                ") must lie within its " + std::to_string(spec.height) + " rows and not be empty");
  }
  rows->Reshape(spec.width, y_end - y_begin, spec.nchannels);
  OIIO::ImageInput& input = *state_->opened.input;
  const bool read =
      state_->native_float
          ? input.read_native_scanlines(0, 0, spec.y + y_begin, spec.y + y_end, 0, 0, spec.nchannels, rows->data())
          : input.read_scanlines(0, 0, spec.y + y_begin, spec.y + y_end, 0, 0, spec.nchannels,
                                 OIIO::TypeDesc::FLOAT, rows->data());
  if (!read) {
    throw PathError(path, "cannot read rows " + std::to_string(y_begin) + " to " + std::to_string(y_end) + " (" +
                              OiioMessage(input.geterror()) + ")");
  }
}

ImageU16 ReadImageU16(const fs::path& path) {
  OpenedInput opened = OpenInput(path);
  RequireInteger(path, opened.spec, 16, "ReadImageU16");
  return ReadPixels<uint16_t>(path, opened, OIIO::TypeDesc::UINT16);
}

ImageU8 ReadImageU8(const fs::path& path) {
  OpenedInput opened = OpenInput(path);
  RequireInteger(path, opened.spec, 8, "ReadImageU8");
  return ReadPixels<uint8_t>(path, opened, OIIO::TypeDesc::UINT8);
}

ImageFileInfo ReadImageFileInfo(const fs::path& path) {
  const OpenedInput opened = OpenInput(path);
  const OIIO::ImageSpec& spec = opened.spec;
  ImageFileInfo info;
  info.width = spec.width;
  info.height = spec.height;
  info.channels = spec.nchannels;
  info.channel_names = spec.channelnames;
  info.is_float = spec.format.is_floating_point();
  info.bits_per_sample = spec.get_int_attribute("oiio:BitsPerSample", static_cast<int>(spec.format.size()) * 8);
  info.compression = spec.get_string_attribute("compression");
  ImageMetadata& metadata = info.metadata;
  // Attribute lines ("scanbench:name=value", TIFF) come out of the description.
  std::istringstream description(spec.get_string_attribute("ImageDescription"));
  std::string line;
  static const std::regex kAttributeLine("(scanbench:[A-Za-z0-9_.]+)=(.*)");
  std::smatch match;
  while (std::getline(description, line)) {
    if (std::regex_match(line, match, kAttributeLine)) {
      metadata.attributes[match[1]] = match[2];
    } else {
      metadata.description += (metadata.description.empty() ? "" : "\n") + line;
    }
  }
  for (const OIIO::ParamValue& value : spec.extra_attribs) {
    const std::string name = value.name().string();
    if (name.rfind("scanbench:", 0) == 0 && value.type() == OIIO::TypeDesc::STRING) {
      metadata.attributes[name] = value.get_string();
    }
  }
  if (auto found = metadata.attributes.find("scanbench:color_space"); found != metadata.attributes.end()) {
    metadata.color_space = found->second;
    metadata.attributes.erase(found);
  }
  // The string holds full precision; OpenEXR's attribute is float, so it only
  // counts when the string is missing (a file written by another program).
  if (auto found = metadata.attributes.find(kChromaticitiesAttribute); found != metadata.attributes.end()) {
    metadata.chromaticities = ParseChromaticities(found->second);
    if (!metadata.chromaticities) {
      throw PathError(path, std::string(kChromaticitiesAttribute) + " = '" + found->second +
                                "' is not 8 finite numbers (rx ry gx gy bx by wx wy)");
    }
    metadata.attributes.erase(found);
  } else if (const OIIO::ParamValue* standard = spec.find_attribute("chromaticities");
             standard != nullptr && standard->type().basetype == OIIO::TypeDesc::FLOAT &&
             standard->type().basevalues() == 8) {
    const float* values = static_cast<const float*>(standard->data());
    std::array<double, 8> exact{};
    for (int i = 0; i < 8; ++i) exact[i] = values[i];
    metadata.chromaticities = ChromaticitiesFrom(exact);
  }
  const float x_resolution = spec.get_float_attribute("XResolution", 0);
  const std::string unit = spec.get_string_attribute("ResolutionUnit");
  if (x_resolution > 0 && (unit == "cm" || unit == "in" || unit == "inch")) {
    info.resolution_mm_per_pixel = (unit == "cm" ? 10.0 : 25.4) / x_resolution;
    metadata.mm_per_pixel = info.resolution_mm_per_pixel;
  }
  if (auto found = metadata.attributes.find("scanbench:mm_per_pixel"); found != metadata.attributes.end()) {
    // The string holds full precision; the resolution tag is a float (PNG: integer pixels per metre).
    try {
      metadata.mm_per_pixel = std::stod(found->second);
    } catch (const std::exception&) {
      throw PathError(path, "scanbench:mm_per_pixel = '" + found->second + "' is not a number");
    }
    metadata.attributes.erase(found);
  }
  return info;
}

ImageMetadata ReadImageMetadata(const fs::path& path) { return ReadImageFileInfo(path).metadata; }

struct ImageRowWriter::State {
  fs::path path, temporary;
  OverwritePolicy policy = OverwritePolicy::kRefuse;
  OIIO::ImageSpec spec;
  OIIO::TypeDesc memory_type;  // what WriteRows takes: FLOAT (EXR), UINT8 or UINT16 (PNG)
  std::optional<ExrEncoding> exr;
  std::unique_ptr<OIIO::ImageOutput> out;
  HalfBuffer halves;  // a half EXR's band, kept from band to band
  int rows_written = 0;
  bool committed = false;

  const char* Format() const { return exr ? "OpenEXR" : "PNG"; }
  void Discard() {
    if (out) out->close();
    out.reset();
    std::error_code ignored;
    fs::remove(temporary, ignored);
  }
};

namespace {

std::unique_ptr<ImageRowWriter::State> OpenRowWriter(const fs::path& path, const char* format,
                                                     const OIIO::ImageSpec& spec, OIIO::TypeDesc memory_type,
                                                     OverwritePolicy policy, std::optional<ExrEncoding> exr) {
  // Fail before encoding anything; CommitTemporaryFile re-checks atomically.
  if (policy == OverwritePolicy::kRefuse && fs::exists(path)) {
    throw PathError(path, "already exists and is never overwritten");
  }
  auto state = std::make_unique<ImageRowWriter::State>();
  state->path = path;
  state->temporary = TemporarySiblingPath(path);
  state->policy = policy;
  state->spec = spec;
  state->memory_type = memory_type;
  state->exr = exr;
  state->out = OIIO::ImageOutput::create(format);
  if (!state->out) throw PathError(path, std::string("no ") + format + " writer (" + OiioMessage(OIIO::geterror()) + ")");
  if (!state->out->open(state->temporary.string(), spec)) {
    const std::string message = state->out->geterror();
    state->Discard();
    throw PathError(path, std::string("cannot be written as ") + format + " (" + OiioMessage(message) + ")");
  }
  return state;
}

template <typename T>
void WriteRowsOf(ImageRowWriter::State* state, const Image<T>& rows, OIIO::TypeDesc type) {
  if (state == nullptr) throw std::logic_error("ImageRowWriter: used after it was moved from");
  const OIIO::ImageSpec& spec = state->spec;
  if (state->committed || type != state->memory_type || rows.width() != spec.width ||
      rows.channels() != spec.nchannels || rows.height() < 1 || rows.height() > spec.height - state->rows_written) {
    throw std::invalid_argument(state->path.string() + ": cannot add " + std::to_string(rows.width()) + "x" +
                                std::to_string(rows.height()) + "x" + std::to_string(rows.channels()) + " " +
                                type.c_str() + " rows to a " + std::to_string(spec.width) + "x" +
                                std::to_string(spec.height) + "x" + std::to_string(spec.nchannels) + " " +
                                state->Format() + " of " + state->memory_type.c_str() + " samples with " +
                                std::to_string(state->rows_written) + " rows written" +
                                (state->committed ? " and committed" : ""));
  }
  const int y_begin = state->rows_written, y_end = y_begin + rows.height();
  bool written = false;
  if (state->exr && state->exr->sample_type == ExrSampleType::kHalf) {
    Imath::half* halves = state->halves.Get(rows.size());
    HalfSamples(reinterpret_cast<const float*>(rows.data()), rows.size(), *state->exr, halves);
    written = state->out->write_scanlines(y_begin, y_end, 0, OIIO::TypeDesc::HALF, halves);
  } else {
    written = state->out->write_scanlines(y_begin, y_end, 0, type, rows.data());
  }
  if (!written) {
    const std::string message = state->out->geterror();
    state->Discard();
    throw PathError(state->path, std::string("writing ") + state->Format() + " rows " + std::to_string(y_begin) +
                                     " to " + std::to_string(y_end) + " failed (" + OiioMessage(message) + ")");
  }
  state->rows_written = y_end;
}

}  // namespace

ImageRowWriter ImageRowWriter::Exr(const fs::path& path, int width, int height, int channels, OverwritePolicy policy,
                                   const std::vector<std::string>& channel_names, const ImageMetadata& metadata,
                                   const ExrEncoding& encoding) {
  if (width <= 0 || height <= 0 || channels <= 0) {
    throw std::invalid_argument(path.string() + ": cannot write an empty " + std::to_string(width) + "x" +
                                std::to_string(height) + "x" + std::to_string(channels) + " image as OpenEXR");
  }
  const OIIO::ImageSpec spec = ExrSpec(path, width, height, channels, channel_names, metadata, encoding);
  return ImageRowWriter(OpenRowWriter(path, "openexr", spec, OIIO::TypeDesc::FLOAT, policy, encoding));
}

ImageRowWriter ImageRowWriter::Png(const fs::path& path, int width, int height, int channels, int bits,
                                   OverwritePolicy policy, const ImageMetadata& metadata, const PngEncoding& encoding) {
  if (width <= 0 || height <= 0 || channels < 1 || channels > 4 || (bits != 8 && bits != 16)) {
    throw std::invalid_argument(path.string() + ": cannot write a " + std::to_string(width) + "x" +
                                std::to_string(height) + "x" + std::to_string(channels) + " " + std::to_string(bits) +
                                "-bit PNG (1 to 4 channels of 8 or 16 bits)");
  }
  const OIIO::TypeDesc type = bits == 16 ? OIIO::TypeDesc::UINT16 : OIIO::TypeDesc::UINT8;
  OIIO::ImageSpec spec(width, height, channels, type);
  spec.attribute("oiio:UnassociatedAlpha", 1);  // as SpecFor: alpha stored as given
  AddPngEncoding(encoding, spec);
  AddMetadata(path, metadata, FileFormat::kPng, spec);
  return ImageRowWriter(OpenRowWriter(path, "png", spec, type, policy, std::nullopt));
}

ImageRowWriter::ImageRowWriter(std::unique_ptr<State> state) : state_(std::move(state)) {}
ImageRowWriter::ImageRowWriter(ImageRowWriter&&) noexcept = default;
ImageRowWriter& ImageRowWriter::operator=(ImageRowWriter&& other) noexcept {
  if (this != &other) {
    if (state_ && !state_->committed) state_->Discard();
    state_ = std::move(other.state_);
  }
  return *this;
}
ImageRowWriter::~ImageRowWriter() {
  if (state_ && !state_->committed) state_->Discard();
}

void ImageRowWriter::WriteRows(const ImageF& rows) { WriteRowsOf(state_.get(), rows, OIIO::TypeDesc::FLOAT); }
void ImageRowWriter::WriteRows(const ImageU8& rows) { WriteRowsOf(state_.get(), rows, OIIO::TypeDesc::UINT8); }
void ImageRowWriter::WriteRows(const ImageU16& rows) { WriteRowsOf(state_.get(), rows, OIIO::TypeDesc::UINT16); }

void ImageRowWriter::Commit() {
  if (!state_ || state_->committed) throw std::logic_error("ImageRowWriter::Commit: nothing to commit");
  if (state_->rows_written != state_->spec.height) {
    throw std::logic_error(state_->path.string() + ": committed with " + std::to_string(state_->rows_written) +
                           " of its " + std::to_string(state_->spec.height) + " rows written");
  }
  const bool closed = state_->out->close();
  if (!closed) {
    const std::string message = state_->out->geterror();
    state_->Discard();
    throw PathError(state_->path, std::string("writing ") + state_->Format() + " failed (" + OiioMessage(message) + ")");
  }
  state_->out.reset();
  state_->committed = true;  // CommitTemporaryFile removes the temporary file itself on failure
  CommitTemporaryFile(state_->temporary, state_->path, state_->policy);
}

const fs::path& ImageRowWriter::path() const { return state_->path; }
int ImageRowWriter::height() const { return state_->spec.height; }
int ImageRowWriter::rows_written() const { return state_->rows_written; }

}  // namespace scanbench
