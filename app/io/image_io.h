// Image files of the project (EXR, PNG, TIFF), all through OpenImageIO.
// Writes are atomic: a temporary sibling, then CommitTemporaryFile under the
// given OverwritePolicy. Pixels are written and read exactly as given: no
// colour-space conversion, no alpha (un)premultiplication.
// Errors are std::runtime_error naming the file and OpenImageIO's message;
// bad arguments are std::invalid_argument.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "app/io/file_util.h"
#include "core/image.h"

namespace scanbench {

// CIE 1931 xy chromaticities of the red, green and blue primaries and of the
// white of the colour space the values are in (OpenEXR's `chromaticities`).
// Declared here so that app/io needs nothing from calibration's colour science;
// calibration/color_science.h's Chromaticities has the same layout.
struct ImageChromaticities {
  double red_x = 0, red_y = 0, green_x = 0, green_y = 0, blue_x = 0, blue_y = 0, white_x = 0, white_y = 0;
};

// Optional metadata stored in the image file itself, so that a file taken out
// of its folder still says how large a pixel is and what its values mean.
struct ImageMetadata {
  // Physical pixel pitch on the sample, mm, finite and >= 0; 0 = not recorded.
  // PNG and TIFF get XResolution / YResolution in pixels per cm with
  // ResolutionUnit "cm" (PNG stores pixels per metre: pHYs); OpenEXR gets
  // pixels per inch (its xDensity; OpenImageIO 2.4 converts "cm" the wrong way
  // for EXR). Always also the string attribute "scanbench:mm_per_pixel".
  double mm_per_pixel = 0;
  std::string description;   // ImageDescription; "" = none
  // Colour space of the values: "Linear", "sRGB" or "Raw" (data, not colour,
  // e.g. normals); "" = none. Stored as oiio:ColorSpace (PNG: gAMA / sRGB
  // chunks) and as "scanbench:color_space".
  std::string color_space;
  // Primaries and white of the values (e.g. Rec.709 / D65 for linear sRGB);
  // every entry finite, white_y > 0; nullopt = not recorded. OpenEXR: the
  // standard `chromaticities` attribute. PNG and TIFF: OpenImageIO 2.4 writes no
  // cHRM for arbitrary primaries (only the fixed sRGB chunk when color_space is
  // "sRGB") and reads none back, so there it is carried only by the string
  // attribute "scanbench:chromaticities" ("rx ry gx gy bx by wx wy"), which
  // every format also gets.
  std::optional<ImageChromaticities> chromaticities;
  // Further string attributes, names of the form "scanbench:name" (letters,
  // digits, '_', '.'); values without line breaks. TIFF keeps no attributes
  // of its own, so there they are also appended to ImageDescription as
  // "scanbench:name=value" lines, which ReadImageMetadata reads back.
  std::map<std::string, std::string> attributes;
};

// How an OpenEXR file stores its samples.
enum class ExrSampleType {
  kFloat32,  // 24-bit mantissa: values exactly as in memory
  // 16-bit half float: 11-bit mantissa (relative step 2^-11 = 4.9e-4 at the
  // top of each octave), largest finite 65504. Values beyond +-65504 are
  // clamped to it, so that no infinity reaches the file.
  kHalf,
};
// The lossless OpenEXR compressions (b44 and dwaa/dwab are lossy and not
// offered; pxr24 is lossless on half only, lossy on float32).
enum class ExrCompression { kNone, kRle, kZips, kZip, kPiz, kPxr24 };
const char* ExrCompressionName(ExrCompression compression);  // OpenEXR's name: "zip", "piz", ...
struct ExrEncoding {
  ExrSampleType sample_type = ExrSampleType::kFloat32;
  ExrCompression compression = ExrCompression::kZip;
  // Half only: values smaller than 1024 steps in magnitude are first rounded
  // to a multiple of this absolute step, where half's own step is finer (it
  // is the step above that), so that the low mantissa bits of small values
  // (noise, for a unit normal's components) do not cost the lossless
  // compressor. A power of two in [2^-24, 1]; 0 = none. The rounding error
  // is at most step / 2, never more than half's own in [512, 1024) steps.
  double half_absolute_step = 0;
};

// OpenEXR, by default 32-bit float with zip compression (`encoding`).
// `channel_names` must be empty or have one name per channel; the default is
// Y / Y,A / R,G,B / R,G,B,A (and OpenImageIO's names for more channels).
// OpenEXR stores channels sorted by name; they read back in the order
// OpenImageIO reports (R,G,B,A first). Throws std::invalid_argument for
// pxr24 with float32 samples (lossy there).
void WriteExr(const std::filesystem::path& path, const ImageF& image, OverwritePolicy policy,
              const std::vector<std::string>& channel_names = {}, const ImageMetadata& metadata = {},
              const ExrEncoding& encoding = {});

// libpng's row filters (PNG spec section 9): one for every row, or libpng's
// per-row choice among all five (the default).
enum class PngFilter { kAdaptive, kNone, kSub, kUp, kAverage, kPaeth };
const char* PngFilterName(PngFilter filter);  // "adaptive", "none", "sub", ...
// zlib's deflate strategies (zlib.h): kDefault matches strings, kFiltered
// favours Huffman coding over matches (for filtered image data), kHuffmanOnly
// matches nothing, kRle matches only runs of the previous byte (distance 1:
// far cheaper to search, and a row filter's output is mostly such runs and
// small values), kFixed uses zlib's fixed Huffman codes.
enum class PngStrategy { kDefault, kFiltered, kHuffmanOnly, kRle, kFixed };
const char* PngStrategyName(PngStrategy strategy);  // "default", "filtered", "huffman", "rle", "fixed"
// How a PNG is deflated; lossless whatever the choice.
struct PngEncoding {
  // zlib level [0, 9]: 0 stores, 9 is smallest and slowest. 1 by default:
  // a 16 MP 16-bit normal map writes in 7.7 s instead of 30 s at zlib's
  // default 6, for 12 % more bytes.
  int zlib_level = 1;
  PngFilter filter = PngFilter::kAdaptive;
  PngStrategy strategy = PngStrategy::kDefault;  // OpenImageIO's "compression" of a PNG
  void Check() const;  // throws std::invalid_argument
};

// PNG, 1 to 4 channels (gray, gray+alpha, RGB, RGBA), 16 or 8 bits.
void WritePng(const std::filesystem::path& path, const ImageU16& image, OverwritePolicy policy,
              const ImageMetadata& metadata = {}, const PngEncoding& encoding = {});
void WritePng(const std::filesystem::path& path, const ImageU8& image, OverwritePolicy policy,
              const ImageMetadata& metadata = {}, const PngEncoding& encoding = {});

// A PNG whose rows a callback fills, written a band of rows at a time through
// OpenImageIO, for large maps: no full-size copy of the pixels is held (the
// export quantises its float maps row by row). The same file as WritePng of
// the same pixels, metadata and encoding.
struct PngRowSource {
  int width = 0, height = 0;  // > 0
  int channels = 0;           // 1 to 4: gray, gray+alpha, RGB, RGBA
  int bits = 16;              // 8 (uint8_t samples) or 16 (uint16_t, host byte order)
  // Fills row y: width * channels samples. Called once per row, y = 0, 1, ... in order.
  std::function<void(int y, void* row)> fill;
};
void WritePngRows(const std::filesystem::path& path, const PngRowSource& rows, OverwritePolicy policy,
                  const ImageMetadata& metadata = {}, const PngEncoding& encoding = {});

// An OpenEXR or PNG written a band of rows at a time, for maps made band by
// band (the solve streams its maps to disk, app/io/result_maps.h): no
// full-size copy of the pixels is held. The file is the whole-image writer's
// (WriteExr / WritePng of the same pixels, channel names, metadata and
// encoding) byte for byte, whatever the bands. It is written under a
// temporary sibling name: Commit() after the last row closes, fsyncs and
// renames it under `policy` (CommitTemporaryFile); a writer destroyed
// uncommitted (an error, a cancelled solve) removes its temporary file.
// Arguments are checked (and a refused existing file reported) on opening.
class ImageRowWriter {
 public:
  // OpenEXR of `channels` float channels, as WriteExr.
  static ImageRowWriter Exr(const std::filesystem::path& path, int width, int height, int channels,
                            OverwritePolicy policy, const std::vector<std::string>& channel_names = {},
                            const ImageMetadata& metadata = {}, const ExrEncoding& encoding = {});
  // PNG of 1 to 4 channels of `bits` 8 or 16, as WritePng.
  static ImageRowWriter Png(const std::filesystem::path& path, int width, int height, int channels, int bits,
                            OverwritePolicy policy, const ImageMetadata& metadata = {},
                            const PngEncoding& encoding = {});
  ImageRowWriter(ImageRowWriter&&) noexcept;
  ImageRowWriter& operator=(ImageRowWriter&&) noexcept;
  ~ImageRowWriter();

  // The next rows, following those written before: the file's width and
  // channels, at most the rows left. ImageF for an EXR, ImageU8 / ImageU16
  // for an 8- / 16-bit PNG (std::invalid_argument otherwise).
  void WriteRows(const ImageF& rows);
  void WriteRows(const ImageU8& rows);
  void WriteRows(const ImageU16& rows);
  // After the last row: the file appears under its name. Throws
  // std::logic_error when rows are missing, std::runtime_error when the
  // write or the rename fails.
  void Commit();

  const std::filesystem::path& path() const;
  int height() const;
  int rows_written() const;

  struct State;  // image_io.cc

 private:
  explicit ImageRowWriter(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

// An 8-bit PNG (1 to 4 channels) encoded in memory, no metadata: for pages
// that carry their images as data: URIs (app/io/preview_page.h).
std::vector<uint8_t> EncodePngInMemory(const ImageU8& image);

// TIFF, zip (deflate) compression: 16-bit unsigned or 32-bit float samples.
void WriteTiff(const std::filesystem::path& path, const ImageU16& image, OverwritePolicy policy,
               const ImageMetadata& metadata = {});
void WriteTiff(const std::filesystem::path& path, const ImageF& image, OverwritePolicy policy,
               const ImageMetadata& metadata = {});

// Any format OpenImageIO reads (first subimage, all channels). Float and
// half files give their stored values; integer files are normalised to
// 0..1 (value / 255 for 8-bit, value / 65535 for 16-bit).
// `channel_names`, if given, receives the channel names in pixel order.
ImageF ReadImageFloat(const std::filesystem::path& path, std::vector<std::string>* channel_names = nullptr);

// Rows [y_begin, y_end) of the same (all channels, y_end - y_begin rows), so
// that a large map can be read band by band: OpenEXR decodes only the chunks
// that hold those rows (PNG decodes from the top each time). Throws
// std::invalid_argument when the rows are not within the image.
ImageF ReadImageFloatRows(const std::filesystem::path& path, int y_begin, int y_end);

// The rows of one image file read band by band from one opened file, the
// values ReadImageFloatRows gives (the solve's ground-truth evaluation reads
// the truth maps so, issue #14). An OpenEXR file is read by OpenImageIO's
// reader on the OpenEXR core library (OpenImageIO's "openexr:core", chosen
// for this file only): a float file's stored rows are copied straight into
// the caller's buffer, about 4x less CPU than the default reader's
// per-line copy on an uncompressed 16 MP float map, the same values (tested).
// Other formats, and an EXR the core reader cannot open, use the default reader.
class ImageRowReader {
 public:
  // Throws std::runtime_error naming the file when it cannot be opened.
  explicit ImageRowReader(const std::filesystem::path& path);
  ImageRowReader(ImageRowReader&&) noexcept;
  ImageRowReader& operator=(ImageRowReader&&) noexcept;
  ~ImageRowReader();

  const std::filesystem::path& path() const;
  int width() const;
  int height() const;
  int channels() const;
  // Rows [y_begin, y_end) into *rows, made width x (y_end - y_begin) x
  // channels (its buffer kept when it already has that shape). Throws as
  // ReadImageFloatRows.
  void ReadRows(int y_begin, int y_end, ImageF* rows);

  struct State;  // image_io.cc

 private:
  std::unique_ptr<State> state_;
};

// Integer files only, values exactly as stored. ReadImageU16 accepts 8- and
// 16-bit files (8-bit values are scaled by 257, so 255 -> 65535);
// ReadImageU8 accepts 8-bit files only. Float files and deeper integer
// files are rejected rather than silently quantised.
ImageU16 ReadImageU16(const std::filesystem::path& path);
ImageU8 ReadImageU8(const std::filesystem::path& path);

// What an image file says about itself: the metadata above as read back
// (mm_per_pixel from XResolution and ResolutionUnit, else from
// "scanbench:mm_per_pixel"; 0 if neither), plus the stored layout.
struct ImageFileInfo {
  int width = 0, height = 0, channels = 0;
  int bits_per_sample = 0;          // 8, 16, 32 (float), ...
  bool is_float = false;
  std::vector<std::string> channel_names;
  // From XResolution and ResolutionUnit alone (cm or inch), 0 if absent; a
  // float tag (PNG: whole pixels per metre), so close to but not exactly
  // metadata.mm_per_pixel.
  double resolution_mm_per_pixel = 0;
  // OpenImageIO's "compression" as read: OpenEXR's ("none", "zip", "piz",
  // ...), TIFF's ("zip", ...); "" where the format reports none (PNG).
  std::string compression;
  ImageMetadata metadata;
};
ImageFileInfo ReadImageFileInfo(const std::filesystem::path& path);
// ReadImageFileInfo(path).metadata.
ImageMetadata ReadImageMetadata(const std::filesystem::path& path);

}  // namespace scanbench
