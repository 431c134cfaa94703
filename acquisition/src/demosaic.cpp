#include "paintlab/acquisition/demosaic.h"

#include <fmt/format.h>

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

}  // namespace paintlab::acq
