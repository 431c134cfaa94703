#include "paintlab/acquisition/demosaic.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"

namespace paintlab::acq {

namespace {

constexpr EnumNames<DemosaicMethod, 2> kDemosaicNames{
    {{DemosaicMethod::Bilinear, "bilinear"}, {DemosaicMethod::EdgeAware, "edge-aware"}}};

// The OpenCV conversion to RGB for a GenICam arrangement (see the header for the naming).
int opencv_code(dev::CfaPattern p, DemosaicMethod m) {
  const bool ea = m == DemosaicMethod::EdgeAware;
  switch (p) {
    case dev::CfaPattern::RG: return ea ? cv::COLOR_BayerBG2RGB_EA : cv::COLOR_BayerBG2RGB;
    case dev::CfaPattern::GR: return ea ? cv::COLOR_BayerGB2RGB_EA : cv::COLOR_BayerGB2RGB;
    case dev::CfaPattern::GB: return ea ? cv::COLOR_BayerGR2RGB_EA : cv::COLOR_BayerGR2RGB;
    case dev::CfaPattern::BG: return ea ? cv::COLOR_BayerRG2RGB_EA : cv::COLOR_BayerRG2RGB;
    case dev::CfaPattern::None: break;
  }
  throw DataError("demosaic: the frame has no colour filter array (pattern none)");
}

}  // namespace

const char* to_string(DemosaicMethod m) { return enum_name(kDemosaicNames, m); }

DemosaicMethod demosaic_method_from_string(const std::string& s, const std::string& where) {
  return enum_from_name(kDemosaicNames, s, "demosaicing method", where);
}

Image<std::uint16_t> demosaic(const Image<std::uint16_t>& mosaic, dev::CfaPattern pattern, DemosaicMethod method) {
  if (mosaic.channels() != 1)
    throw DataError(fmt::format("demosaic: a mosaic has one plane, not {}", mosaic.channels()));
  if (mosaic.width() < 2 || mosaic.height() < 2)
    throw DataError(fmt::format("demosaic: a {}x{} mosaic holds no 2x2 filter block", mosaic.width(), mosaic.height()));
  const int code = opencv_code(pattern, method);
  Image<std::uint16_t> rgb(mosaic.width(), mosaic.height(), 3);
  // OpenCV reads and writes our buffers in place (row-major, channels interleaved).
  const cv::Mat in(mosaic.height(), mosaic.width(), CV_16UC1, const_cast<std::uint16_t*>(mosaic.data()));
  cv::Mat out(rgb.height(), rgb.width(), CV_16UC3, rgb.data());
  cv::demosaicing(in, out, code, 3);
  return rgb;
}

ExrImage demosaic_merged(const ExrImage& mosaic, dev::CfaPattern pattern) {
  if (pattern == dev::CfaPattern::None) throw DataError("demosaic: the merged image has no colour filter array (pattern none)");
  const ImageF* value = mosaic.find("Y");
  const ImageF* variance = mosaic.find("var.Y");
  const ImageF* valid = mosaic.find("valid");
  if (!value || !variance || !valid)
    throw DataError("demosaic: a merged mosaic has the planes Y, var.Y and valid (the HDR merge of a Bayer bracket)");
  const int w = mosaic.width, h = mosaic.height;
  ExrImage out;
  out.width = w;
  out.height = h;
  out.attributes = mosaic.attributes;
  const char* names[3] = {"R", "G", "B"};
  ImageF rgb[3], var[3];
  for (int c = 0; c < 3; ++c) {
    rgb[c] = ImageF(w, h, 1);
    var[c] = ImageF(w, h, 1);
  }
  ImageF ok(w, h, 1, 1.0f);
  const float inf = std::numeric_limits<float>::infinity();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double sum[3] = {0, 0, 0}, sum_w[3] = {0, 0, 0}, sum_var[3] = {0, 0, 0};
      bool all_valid[3] = {true, true, true};
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int sx = x + dx, sy = y + dy;
          if (sx < 0 || sy < 0 || sx >= w || sy >= h) continue;
          const int c = dev::cfa_colour(pattern, sx, sy);
          const double k = (2 - std::abs(dx)) * (2 - std::abs(dy));
          sum[c] += k * value->at(sx, sy);
          sum_w[c] += k;
          sum_var[c] += k * k * variance->at(sx, sy);
          all_valid[c] = all_valid[c] && valid->at(sx, sy) > 0.5f;
        }
      for (int c = 0; c < 3; ++c) {
        rgb[c].at(x, y) = static_cast<float>(sum[c] / sum_w[c]);
        var[c].at(x, y) = all_valid[c] ? static_cast<float>(sum_var[c] / (sum_w[c] * sum_w[c])) : inf;
        if (!all_valid[c]) ok.at(x, y) = 0.0f;
      }
    }
  for (int c = 0; c < 3; ++c) out.add(names[c], std::move(rgb[c]));
  for (int c = 0; c < 3; ++c) out.add(std::string("var.") + names[c], std::move(var[c]));
  out.add("valid", std::move(ok));
  return out;
}

ImageF cfa_luminance(const ImageF& mosaic) {
  if (mosaic.channels() != 1) throw DataError(fmt::format("cfa luminance: a mosaic has one plane, not {}", mosaic.channels()));
  const int w = mosaic.width(), h = mosaic.height();
  ImageF out(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double sum = 0, sum_w = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int sx = x + dx, sy = y + dy;
          if (sx < 0 || sy < 0 || sx >= w || sy >= h) continue;
          const double k = (2 - std::abs(dx)) * (2 - std::abs(dy));
          sum += k * mosaic.at(sx, sy);
          sum_w += k;
        }
      out.at(x, y) = static_cast<float>(sum / sum_w);
    }
  return out;
}

}  // namespace paintlab::acq
