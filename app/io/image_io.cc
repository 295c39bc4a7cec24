#include "app/io/image_io.h"

#include <OpenImageIO/imageio.h>

#include <stdexcept>
#include <system_error>

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
void WriteAtomically(const fs::path& path, const char* format, const OIIO::ImageSpec& spec, const void* pixels,
                     OverwritePolicy policy) {
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
  const bool written = out->write_image(spec.format, pixels);
  const bool closed = out->close();
  if (!written || !closed) {
    const std::string message = out->geterror();
    discard();
    throw PathError(path, std::string("writing ") + format + " failed (" + OiioMessage(message) + ")");
  }
  out.reset();
  CommitTemporaryFile(temporary, path, policy);
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

struct OpenedInput {
  std::unique_ptr<OIIO::ImageInput> input;
  OIIO::ImageSpec spec;
};

OpenedInput OpenInput(const fs::path& path) {
  if (!fs::exists(path)) throw PathError(path, "does not exist");
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  OpenedInput opened;
  opened.input = OIIO::ImageInput::open(path.string(), &config);
  if (!opened.input) {
    throw PathError(path, "cannot be read as an image (" + OiioMessage(OIIO::geterror()) + ")");
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

}  // namespace

void WriteExr(const fs::path& path, const ImageF& image, OverwritePolicy policy,
              const std::vector<std::string>& channel_names) {
  CheckWritable(path, image, "OpenEXR", 0);
  if (!channel_names.empty() && static_cast<int>(channel_names.size()) != image.channels()) {
    throw std::invalid_argument(path.string() + ": " + std::to_string(channel_names.size()) +
                                " channel names given for an image with " + std::to_string(image.channels()) +
                                " channels");
  }
  OIIO::ImageSpec spec = SpecFor(image, OIIO::TypeDesc::FLOAT);
  const std::vector<std::string> names = channel_names.empty() ? DefaultChannelNames(image.channels()) : channel_names;
  if (!names.empty()) {
    spec.channelnames = names;
    spec.alpha_channel = -1;
    for (int c = 0; c < image.channels(); ++c) {
      if (names[c] == "A") spec.alpha_channel = c;
    }
  }
  spec.attribute("compression", "zip");
  WriteAtomically(path, "openexr", spec, image.data(), policy);
}

void WritePng(const fs::path& path, const ImageU16& image, OverwritePolicy policy) {
  CheckWritable(path, image, "PNG", 4);
  WriteAtomically(path, "png", SpecFor(image, OIIO::TypeDesc::UINT16), image.data(), policy);
}

void WritePng(const fs::path& path, const ImageU8& image, OverwritePolicy policy) {
  CheckWritable(path, image, "PNG", 4);
  WriteAtomically(path, "png", SpecFor(image, OIIO::TypeDesc::UINT8), image.data(), policy);
}

void WriteTiff(const fs::path& path, const ImageU16& image, OverwritePolicy policy) {
  CheckWritable(path, image, "TIFF", 0);
  OIIO::ImageSpec spec = SpecFor(image, OIIO::TypeDesc::UINT16);
  spec.attribute("compression", "zip");
  WriteAtomically(path, "tiff", spec, image.data(), policy);
}

void WriteTiff(const fs::path& path, const ImageF& image, OverwritePolicy policy) {
  CheckWritable(path, image, "TIFF", 0);
  OIIO::ImageSpec spec = SpecFor(image, OIIO::TypeDesc::FLOAT);
  spec.attribute("compression", "zip");
  WriteAtomically(path, "tiff", spec, image.data(), policy);
}

ImageF ReadImageFloat(const fs::path& path, std::vector<std::string>* channel_names) {
  OpenedInput opened = OpenInput(path);
  ImageF image = ReadPixels<float>(path, opened, OIIO::TypeDesc::FLOAT);
  if (channel_names) *channel_names = opened.spec.channelnames;
  return image;
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

}  // namespace scanbench
