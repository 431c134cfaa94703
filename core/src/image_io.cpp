#include "paintlab/core/image_io.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <ImathBox.h>
#include <half.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <fmt/format.h>

#include <ImfIO.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <string_view>
#include <utility>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/input_files.h"

namespace fs = std::filesystem;

namespace paintlab {

const ImageF& ExrImage::plane(const std::string& name) const {
  if (const ImageF* p = find(name)) return *p;
  throw DataError("EXR image has no channel '" + name + "'");
}

ImageF* ExrImage::find(const std::string& name) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return &planes[i];
  return nullptr;
}

const ImageF* ExrImage::find(const std::string& name) const {
  return const_cast<ExrImage*>(this)->find(name);
}

void ExrImage::add(const std::string& name, ImageF plane) {
  if (names.empty() && width == 0) {
    width = plane.width();
    height = plane.height();
  }
  if (plane.width() != width || plane.height() != height || plane.channels() != 1)
    throw DataError("EXR channel '" + name + "' does not match the image size");
  if (ImageF* p = find(name)) {
    *p = std::move(plane);
    return;
  }
  names.push_back(name);
  planes.push_back(std::move(plane));
}

void write_exr(const fs::path& path, const ExrImage& image, bool half) {
  if (image.names.empty()) throw DataError(path.string() + ": refusing to write an EXR without channels");
  write_via_temp(path, [&](const fs::path& tmp) {
    try {
      Imf::Header header(image.width, image.height);
      header.compression() = Imf::ZIP_COMPRESSION;
      for (const auto& [k, v] : image.attributes) header.insert(k, Imf::StringAttribute(v));
      Imf::PixelType type = half ? Imf::HALF : Imf::FLOAT;
      for (const auto& n : image.names) header.channels().insert(n, Imf::Channel(type));
      std::vector<std::vector<::half>> half_planes;
      Imf::FrameBuffer fb;
      for (std::size_t i = 0; i < image.names.size(); ++i) {
        const ImageF& p = image.planes[i];
        if (half) {
          half_planes.emplace_back(p.values().begin(), p.values().end());
          fb.insert(image.names[i], Imf::Slice(Imf::HALF, reinterpret_cast<char*>(half_planes.back().data()),
                                               sizeof(::half), sizeof(::half) * image.width));
        } else {
          fb.insert(image.names[i], Imf::Slice(Imf::FLOAT, const_cast<char*>(reinterpret_cast<const char*>(p.data())),
                                               sizeof(float), sizeof(float) * image.width));
        }
      }
      Imf::OutputFile file(tmp.c_str(), header);
      file.setFrameBuffer(fb);
      file.writePixels(image.height);
    } catch (const Error&) {
      throw;
    } catch (const std::exception& e) {
      throw IoError(path.string(), std::string("cannot write EXR: ") + e.what(), 0, IoOp::Write);
    }
  });
}

namespace {

// An OpenEXR input stream over a file's bytes already in memory (read once, checked by
// check_exr_header, then parsed by OpenEXR without a second open).
class ExrMemoryStream final : public Imf::IStream {
 public:
  ExrMemoryStream(const fs::path& path, std::string_view bytes) : Imf::IStream(path.c_str()), bytes_(bytes) {}
  bool read(char c[], int n) override {
    if (n < 0 || static_cast<std::uint64_t>(n) > bytes_.size() - pos_)
      throw std::runtime_error("unexpected end of file");
    std::memcpy(c, bytes_.data() + pos_, static_cast<std::size_t>(n));
    pos_ += static_cast<std::uint64_t>(n);
    return pos_ < bytes_.size();
  }
  std::uint64_t tellg() override { return pos_; }
  void seekg(std::uint64_t pos) override {
    if (pos > bytes_.size()) throw std::runtime_error("seek past the end of the file");
    pos_ = pos;
  }

 private:
  std::string_view bytes_;
  std::uint64_t pos_ = 0;
};

constexpr std::size_t kSizeFromHeader = static_cast<std::size_t>(-1);
constexpr std::size_t kNotWellFormed = static_cast<std::size_t>(-2);

// The size OpenEXR's reader takes for an attribute value of `type` (OpenEXR 3.1: fixed sizes
// for the numeric types, a zero-terminated list for channel lists, width x height x 4 bytes
// after the sides for previews); kSizeFromHeader for the types it reads by the stated size
// (strings, vectors, types it does not know).
std::size_t implied_exr_attribute_size(std::string_view type, std::string_view value) {
  static constexpr std::pair<std::string_view, std::size_t> kFixed[] = {
      {"box2i", 16},          {"box2f", 16},    {"chromaticities", 32}, {"compression", 1}, {"double", 8},
      {"envmap", 1},          {"float", 4},     {"int", 4},             {"keycode", 28},    {"lineOrder", 1},
      {"m33f", 36},           {"m33d", 72},     {"m44f", 64},           {"m44d", 128},      {"rational", 8},
      {"tiledesc", 9},        {"timecode", 8},  {"v2i", 8},             {"v2f", 8},         {"v2d", 16},
      {"v3i", 12},            {"v3f", 12},      {"v3d", 24},            {"deepImageState", 1}};
  for (const auto& [name, size] : kFixed)
    if (type == name) return size;
  const auto u32 = [&](std::size_t i) {
    std::uint32_t v = 0;
    for (int b = 3; b >= 0; --b) v = v << 8 | static_cast<unsigned char>(value[i + static_cast<std::size_t>(b)]);
    return v;
  };
  if (type == "chlist") {
    // Per channel: name\0 (at most 255 characters), pixel type, pLinear + 3 reserved bytes,
    // x and y sampling (16 bytes); an empty name ends the list.
    std::size_t at = 0;
    while (true) {
      const std::size_t end = value.find('\0', at);
      if (end == std::string_view::npos || end - at > 255) return kNotWellFormed;
      if (end == at) return at + 1;
      at = end + 1 + 16;
      if (at > value.size()) return kNotWellFormed;
    }
  }
  if (type == "preview") {
    if (value.size() < 8) return kNotWellFormed;
    const std::uint64_t pixels = std::uint64_t{u32(0)} * u32(4);
    return pixels > value.size() ? kNotWellFormed : static_cast<std::size_t>(8 + 4 * pixels);
  }
  return kSizeFromHeader;
}

// Walks the header(s) of an OpenEXR file (the layout of openexr.com's "OpenEXR File Layout":
// magic number 20000630, a version word whose bit 12 marks multi-part files and bit 10 long
// attribute names, then per header attributes of name\0 type\0 int32-size value, ended by an
// empty name; multi-part files end their list of headers with an empty header) and refuses an
// attribute whose stated size runs past the end of the file. OpenEXR sizes a string or unknown
// attribute from that number before it reads it: one damaged size word would make it allocate
// and clear up to 2 GB for a file of a few hundred bytes.
void check_exr_header(const fs::path& path, std::string_view bytes) {
  auto damaged = [&](const std::string& what) {
    return DataError(path.string() + ": not a readable OpenEXR file: " + what);
  };
  if (bytes.size() < 8) throw damaged("shorter than an OpenEXR header");
  const auto u8 = [&](std::size_t i) { return static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i])); };
  const auto word = [&](std::size_t i) { return u8(i) | u8(i + 1) << 8 | u8(i + 2) << 16 | u8(i + 3) << 24; };
  if (word(0) != 20000630u) throw damaged("no OpenEXR magic number");
  const std::uint32_t version = word(4);
  const bool multipart = (version & 0x1000u) != 0;
  const std::size_t max_name = (version & 0x400u) ? 255 : 31;
  std::size_t at = 8;
  auto name_at = [&](const char* what) {
    const std::size_t end = bytes.find('\0', at);
    if (end == std::string_view::npos || end - at > max_name)
      throw damaged(fmt::format("the header's {} at byte {} is not a name of at most {} characters", what, at, max_name));
    std::string name(bytes.substr(at, end - at));
    at = end + 1;
    return name;
  };
  while (true) {
    int attributes = 0;
    for (;; ++attributes) {
      const std::string name = name_at("attribute name");
      if (name.empty()) break;
      const std::string type = name_at("attribute type");
      if (bytes.size() - at < 4) throw damaged(fmt::format("attribute '{}' has no size", name));
      const auto size = static_cast<std::int32_t>(word(at));
      at += 4;
      if (size < 0 || static_cast<std::size_t>(size) > bytes.size() - at)
        throw damaged(fmt::format("attribute '{}' ({}) states {} bytes where the file has {} left: the header is damaged",
                                  name, type, size, bytes.size() - at));
      const std::string_view value = bytes.substr(at, static_cast<std::size_t>(size));
      // OpenEXR reads a value of a known type by its type, not by the stated size: the size
      // must be the one the type implies, or OpenEXR would go on reading from another place
      // than this walk.
      const std::size_t implied = implied_exr_attribute_size(type, value);
      if (implied != kSizeFromHeader && implied != value.size())
        throw damaged(fmt::format("attribute '{}' ({}) states {} bytes where its content takes {}: the header is damaged",
                                  name, type, size, implied == kNotWellFormed ? std::string("more") : std::to_string(implied)));
      at += value.size();
    }
    // A single-part file has one header; a multi-part file's list ends with an empty one.
    if (!multipart || attributes == 0) return;
  }
}

}  // namespace

ExrImage read_exr(const fs::path& path, const ExrLimits& limits) {
  require_readable_file(path);
  const std::string bytes = read_file(path);
  check_exr_header(path, bytes);
  try {
    // OpenEXR checks the header's window and tile sizes against these before it allocates the
    // line-offset table of a damaged file (process-wide; set once, before the first open).
    // Smaller limits than the defaults (the fuzz harness) set OpenEXR's checks for every read
    // after them: they are for a process that reads only such images.
    const int side = static_cast<int>(std::min(limits.max_side, kMaxExrSide));
    static std::once_flag openexr_limits;
    if (side < kMaxExrSide) {
      Imf::Header::setMaxImageSize(side, side);
      Imf::Header::setMaxTileSize(side, side);
    } else {
      std::call_once(openexr_limits, [] {
        Imf::Header::setMaxImageSize(static_cast<int>(kMaxExrSide), static_cast<int>(kMaxExrSide));
        Imf::Header::setMaxTileSize(static_cast<int>(kMaxExrSide), static_cast<int>(kMaxExrSide));
      });
    }
    ExrMemoryStream stream(path, bytes);
    Imf::InputFile file(stream);
    Imath::Box2i dw = file.header().dataWindow();
    // A damaged header can state any window: bound it before allocating (the largest image a
    // rig writes is a few Mpx; a window of 2^31 rows would otherwise overflow or exhaust memory).
    const std::int64_t w = std::int64_t{dw.max.x} - dw.min.x + 1, h = std::int64_t{dw.max.y} - dw.min.y + 1;
    std::int64_t channels = 0;
    for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it) ++channels;
    const std::int64_t max_side = std::min(limits.max_side, kMaxExrSide);
    if (w < 1 || h < 1 || w > max_side || h > max_side || w * h * std::max<std::int64_t>(channels, 1) > limits.max_values)
      throw DataError(fmt::format("{}: data window {} x {} with {} channels is outside what paintlab reads (sides 1..{}, "
                                  "at most {} values)",
                                  path.string(), w, h, channels, max_side, limits.max_values));
    ExrImage img;
    img.width = static_cast<int>(w);
    img.height = static_cast<int>(h);
    for (auto it = file.header().begin(); it != file.header().end(); ++it) {
      if (auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute())) img.attributes[it.name()] = s->value();
    }
    Imf::FrameBuffer fb;
    for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it) {
      img.names.push_back(it.name());
      img.planes.emplace_back(img.width, img.height, 1);
    }
    for (std::size_t i = 0; i < img.names.size(); ++i) {
      char* base = reinterpret_cast<char*>(img.planes[i].data()) -
                   (static_cast<std::ptrdiff_t>(dw.min.x) + static_cast<std::ptrdiff_t>(dw.min.y) * img.width) *
                       static_cast<std::ptrdiff_t>(sizeof(float));
      fb.insert(img.names[i], Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * img.width));
    }
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    return img;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw DataError(path.string() + ": not a readable OpenEXR file: " + e.what());
  }
}

RawImage read_raw_image(const fs::path& path) {
  require_readable_file(path);
  cv::Mat m = cv::imread(path.string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  if (m.empty()) throw DataError(path.string() + ": not a readable image (PNG, TIFF, PGM, JPEG)");
  if (m.depth() != CV_8U && m.depth() != CV_16U)
    throw DataError(path.string() + ": unsupported pixel depth (need 8 or 16 bit integer)");
  if (m.channels() != 1 && m.channels() != 3)
    throw DataError(path.string() + ": unsupported channel count " + std::to_string(m.channels()));
  if (m.channels() == 3) cv::cvtColor(m, m, cv::COLOR_BGR2RGB);
  RawImage out;
  out.bit_depth = m.depth() == CV_8U ? 8 : 16;
  out.pixels = Image<std::uint16_t>(m.cols, m.rows, m.channels());
  cv::Mat dst(m.rows, m.cols, CV_16UC(m.channels()), out.pixels.data());
  m.convertTo(dst, CV_16U);
  return out;
}

void write_png(const fs::path& path, const Image<std::uint16_t>& pixels, int bit_depth) {
  if (pixels.channels() != 1 && pixels.channels() != 3) throw DataError(path.string() + ": PNG needs 1 or 3 channels");
  cv::Mat src(pixels.height(), pixels.width(), CV_16UC(pixels.channels()),
              const_cast<std::uint16_t*>(pixels.data()));
  cv::Mat m;
  if (bit_depth == 8) src.convertTo(m, CV_8U);
  else m = src.clone();
  if (m.channels() == 3) cv::cvtColor(m, m, cv::COLOR_RGB2BGR);
  std::vector<uchar> buf;
  if (!cv::imencode(".png", m, buf)) throw IoError(path.string(), "PNG encoding failed");
  write_file_atomic(path, std::string_view(reinterpret_cast<const char*>(buf.data()), buf.size()));
}

void write_png8(const fs::path& path, const Image<std::uint8_t>& pixels) {
  cv::Mat m(pixels.height(), pixels.width(), CV_8UC(pixels.channels()), const_cast<std::uint8_t*>(pixels.data()));
  cv::Mat out;
  if (m.channels() == 3) cv::cvtColor(m, out, cv::COLOR_RGB2BGR);
  else out = m;
  std::vector<uchar> buf;
  if (!cv::imencode(".png", out, buf)) throw IoError(path.string(), "PNG encoding failed");
  write_file_atomic(path, std::string_view(reinterpret_cast<const char*>(buf.data()), buf.size()));
}

}  // namespace paintlab
