#include "paintlab/acquisition/demosaic.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

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

ImageF demosaic_bilinear(const ImageF& mosaic, dev::CfaPattern pattern) {
  if (mosaic.channels() != 1) throw DataError(fmt::format("demosaic: a mosaic has one plane, not {}", mosaic.channels()));
  ExrImage m;
  m.add("Y", mosaic);
  m.add("var.Y", ImageF(mosaic.width(), mosaic.height(), 1, 0.0f));
  m.add("valid", ImageF(mosaic.width(), mosaic.height(), 1, 1.0f));
  const ExrImage rgb = demosaic_merged(m, pattern);
  ImageF out(mosaic.width(), mosaic.height(), 3);
  const char* names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; ++c) {
    const ImageF& plane = rgb.plane(names[c]);
    for (int y = 0; y < out.height(); ++y)
      for (int x = 0; x < out.width(); ++x) out.at(x, y, c) = plane.at(x, y);
  }
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

std::optional<std::array<double, 3>> grey_gains(const ImageF& mosaic, dev::CfaPattern pattern, int min_blocks) {
  if (mosaic.channels() != 1) throw DataError(fmt::format("cfa luminance: a mosaic has one plane, not {}", mosaic.channels()));
  if (pattern == dev::CfaPattern::None) throw DataError("cfa luminance: the frame has no colour filter array (pattern none)");
  // The scale of the image: its 99th percentile (a highlight, a hot or clipped pixel is not).
  float peak = 0.0f;
  if (!mosaic.empty()) {
    std::vector<float> v(mosaic.values().begin(), mosaic.values().end());
    const auto q = v.begin() + static_cast<std::ptrdiff_t>(0.99 * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), q, v.end());
    peak = *q;
  }
  // Per 2x2 block of a flat part of the image (every site between 20 % and 100 % of the
  // image's scale, its two greens within 5 % of each other: no edge, no highlight's flank
  // runs through it) the red and blue sites against the greens' mean; the medians are the gains.
  std::vector<double> ratio[3];
  for (int y = 0; y + 1 < mosaic.height(); y += 2)
    for (int x = 0; x + 1 < mosaic.width(); x += 2) {
      double site[3] = {0, 0, 0}, green[2] = {0, 0};
      int greens = 0;
      bool usable = true;
      for (int k = 0; k < 4 && usable; ++k) {
        const float v = mosaic.at(x + (k & 1), y + (k >> 1));
        usable = v >= 0.2f * peak && v <= peak;
        const int c = dev::cfa_colour(pattern, x + (k & 1), y + (k >> 1));
        if (c == 1) green[greens++ & 1] = v;
        else site[c] = v;
      }
      if (!usable || std::abs(green[0] - green[1]) > 0.025 * (green[0] + green[1])) continue;
      const double g_mean = 0.5 * (green[0] + green[1]);
      ratio[0].push_back(site[0] / g_mean);
      ratio[2].push_back(site[2] / g_mean);
    }
  if (static_cast<int>(ratio[0].size()) < std::max(min_blocks, 1)) return std::nullopt;
  // Grey seen well gives one ratio everywhere; blocks of noise (a dark image) scatter: their
  // median would be a number without meaning. The ratios' spread (MAD) must stay within 3 %.
  std::array<double, 3> g{1.0, 1.0, 1.0};
  for (int c : {0, 2}) {
    auto& r = ratio[static_cast<std::size_t>(c)];
    const auto mid = r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2);
    std::nth_element(r.begin(), mid, r.end());
    const double median = *mid;
    if (!(median > 0)) return std::nullopt;
    std::vector<double> dev;
    dev.reserve(r.size());
    for (double v : r) dev.push_back(std::abs(v - median));
    const auto dmid = dev.begin() + static_cast<std::ptrdiff_t>(dev.size() / 2);
    std::nth_element(dev.begin(), dmid, dev.end());
    if (*dmid > 0.03 * median) return std::nullopt;
    g[static_cast<std::size_t>(c)] = median;
  }
  return g;
}

ImageF balanced_luminance(const ImageF& mosaic, dev::CfaPattern pattern, const std::array<double, 3>& g) {
  if (mosaic.channels() != 1) throw DataError(fmt::format("cfa luminance: a mosaic has one plane, not {}", mosaic.channels()));
  ImageF balanced(mosaic.width(), mosaic.height(), 1);
  for (int y = 0; y < mosaic.height(); ++y)
    for (int x = 0; x < mosaic.width(); ++x)
      balanced.at(x, y) = static_cast<float>(mosaic.at(x, y) / g[static_cast<std::size_t>(dev::cfa_colour(pattern, x, y))]);
  return cfa_luminance(balanced);
}

}  // namespace paintlab::acq
