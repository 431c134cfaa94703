#pragma once
// Colour from a colour-filter-array (Bayer) frame: the mosaic (one plane, at each pixel the
// colour its filter passes) to camera RGB at every pixel, with OpenCV's cv::demosaicing.
//
// OpenCV names a Bayer arrangement after the 2x2 block at row 1, column 1 (counting from 0),
// GenICam after the block at the top-left corner: GenICam BayerRG (R G / G B) is OpenCV's
// BayerBG, GR is GB, GB is GR, BG is RG (opencv/opencv issues 4857, 19629). demosaic() takes
// GenICam's name (dev::CfaPattern, what the camera reports) and translates.
#include <cstdint>
#include <string>

#include "paintlab/core/image.h"
#include "paintlab/devices/camera.h"

namespace paintlab::acq {

enum class DemosaicMethod {
  Bilinear,   // each missing colour the mean of its nearest neighbours of that colour
  EdgeAware,  // OpenCV's edge-aware variant (_EA): interpolates along edges, less zipper
};
const char* to_string(DemosaicMethod m);  // "bilinear", "edge-aware"
// DataError naming `where` and the methods for another name.
DemosaicMethod demosaic_method_from_string(const std::string& s, const std::string& where);

// The RGB image (3 channels R, G, B; the mosaic's size and value range) of a one-plane
// mosaic of `pattern`. DataError for a mosaic that is not one plane, smaller than 2x2, or
// pattern None.
Image<std::uint16_t> demosaic(const Image<std::uint16_t>& mosaic, dev::CfaPattern pattern,
                              DemosaicMethod method = DemosaicMethod::EdgeAware);

}  // namespace paintlab::acq
