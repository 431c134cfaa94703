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

#include <algorithm>
#include <cstdint>
#include <mutex>

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

ExrImage read_exr(const fs::path& path, const ExrLimits& limits) {
  require_readable_file(path);
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
    Imf::InputFile file(path.c_str());
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
