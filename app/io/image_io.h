// Image files of the project (EXR, PNG, TIFF), all through OpenImageIO.
// Writes are atomic: a temporary sibling, then CommitTemporaryFile under the
// given OverwritePolicy. Pixels are written and read exactly as given: no
// colour-space conversion, no alpha (un)premultiplication.
// Errors are std::runtime_error naming the file and OpenImageIO's message;
// bad arguments are std::invalid_argument.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "app/io/file_util.h"
#include "solver/image.h"

namespace scanbench {

// 32-bit float OpenEXR, zip compression. `channel_names` must be empty or
// have one name per channel; the default is Y / Y,A / R,G,B / R,G,B,A (and
// OpenImageIO's names for more channels). OpenEXR stores channels sorted by
// name; they read back in the order OpenImageIO reports (R,G,B,A first).
void WriteExr(const std::filesystem::path& path, const ImageF& image, OverwritePolicy policy,
              const std::vector<std::string>& channel_names = {});

// PNG, 1 to 4 channels (gray, gray+alpha, RGB, RGBA), 16 or 8 bits.
void WritePng(const std::filesystem::path& path, const ImageU16& image, OverwritePolicy policy);
void WritePng(const std::filesystem::path& path, const ImageU8& image, OverwritePolicy policy);

// TIFF, zip (deflate) compression: 16-bit unsigned or 32-bit float samples.
void WriteTiff(const std::filesystem::path& path, const ImageU16& image, OverwritePolicy policy);
void WriteTiff(const std::filesystem::path& path, const ImageF& image, OverwritePolicy policy);

// Any format OpenImageIO reads (first subimage, all channels). Float and
// half files give their stored values; integer files are normalised to
// 0..1 (value / 255 for 8-bit, value / 65535 for 16-bit).
// `channel_names`, if given, receives the channel names in pixel order.
ImageF ReadImageFloat(const std::filesystem::path& path, std::vector<std::string>* channel_names = nullptr);

// Integer files only, values exactly as stored. ReadImageU16 accepts 8- and
// 16-bit files (8-bit values are scaled by 257, so 255 -> 65535);
// ReadImageU8 accepts 8-bit files only. Float files and deeper integer
// files are rejected rather than silently quantised.
ImageU16 ReadImageU16(const std::filesystem::path& path);
ImageU8 ReadImageU8(const std::filesystem::path& path);

}  // namespace scanbench
