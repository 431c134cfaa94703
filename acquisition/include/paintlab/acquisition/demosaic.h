#pragma once
// Colour from a colour-filter-array (Bayer) frame: the mosaic (one plane, at each pixel the
// colour its filter passes) to camera RGB at every pixel, with OpenCV's cv::demosaicing.
//
// OpenCV names a Bayer arrangement after the 2x2 block at row 1, column 1 (counting from 0),
// GenICam after the block at the top-left corner: GenICam BayerRG (R G / G B) is OpenCV's
// BayerBG, GR is GB, GB is GR, BG is RG (opencv/opencv issues 4857, 19629). demosaic() takes
// GenICam's name (dev::CfaPattern, what the camera reports) and translates.
#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "paintlab/core/colour.h"
#include "paintlab/core/image.h"
#include "paintlab/core/image_io.h"
#include "paintlab/devices/camera.h"

namespace paintlab::acq {

enum class DemosaicMethod {
  Bilinear,   // each missing colour the mean of its nearest neighbours of that colour
  EdgeAware,  // OpenCV's edge-aware variant (_EA): interpolates along edges, less zipper
};
const char* to_string(DemosaicMethod m);  // "bilinear", "edge-aware"
// DataError naming `where` and the methods for another name.
DemosaicMethod demosaic_method_from_string(const std::string& s, const std::string& where);

// How demosaic_to_colour fills in the two colours a site of a merged mosaic does not see.
enum class MosaicInterpolation {
  // The mean of the nearest sites of that colour (two or four; cv::demosaicing's bilinear
  // kernel). Spreads a highlight of a few pixels over its 3x3 neighbourhood in those colours.
  Bilinear,
  // Malvar, He and Cutler (ICASSP 2004, "High-quality linear interpolation for demosaicing of
  // Bayer-patterned color images"): the bilinear estimate corrected by the Laplacian of the
  // site's own colour over a 5x5 neighbourhood (their kernels, gains 1/2, 5/8, 3/4), on the
  // white-balanced mosaic so that a grey highlight is grey in every colour. Linear, so the
  // variance follows exactly; the two pixels next to the border stay bilinear.
  GradientCorrected,
};
const char* to_string(MosaicInterpolation m);  // "bilinear", "gradient-corrected"
// DataError naming `where` and the methods for another name.
MosaicInterpolation mosaic_interpolation_from_string(const std::string& s, const std::string& where);

// The RGB image (3 channels R, G, B; the mosaic's size and value range) of a one-plane
// mosaic of `pattern`. DataError for a mosaic that is not one plane, smaller than 2x2, or
// pattern None.
Image<std::uint16_t> demosaic(const Image<std::uint16_t>& mosaic, dev::CfaPattern pattern,
                              DemosaicMethod method = DemosaicMethod::EdgeAware);

// A merged radiance mosaic as camera RGB: the HDR merge of a Bayer bracket is one plane per
// pixel (channels Y, var.Y, valid; each pixel the radiance of its filter's colour), this gives
// R, G, B, var.R, var.G, var.B, valid. Bilinear, written out rather than OpenCV's because the
// merge's variance and validity have to follow: a site keeps its own colour's value; another
// colour c is the weighted mean of the sites of colour c in its 3x3 neighbourhood, weights
// (2 - |dx|)(2 - |dy|) (a green between two reds takes their mean, a red among four diagonal
// blues the mean of the four, a green at a red site the mean of its four green neighbours:
// cv::demosaicing's bilinear kernel); the variance is sum w^2 var / (sum w)^2, and the value is
// valid only where every site it used is. Attributes are carried over.
// DataError for a mosaic without Y, var.Y and valid, or pattern None.
ExrImage demosaic_merged(const ExrImage& mosaic, dev::CfaPattern pattern);

// What a colour session stores of the camera's RGB: out = M (balance .* camera), with the
// variance carried through (sum_j M_ij^2 balance_j^2 var_j; the demosaiced channels of one
// pixel come from different sites and are independent). `matrix` unset: out = balance .*
// camera (camera RGB). A non-linear map (the colour calibration's root polynomials) is given
// as `nonlinear`, evaluated per pixel with its variance through the map's Jacobian.
struct ColourMap {
  dev::CfaPattern pattern = dev::CfaPattern::None;
  std::array<double, 3> balance{1.0, 1.0, 1.0};
  std::optional<std::array<double, 9>> matrix{};  // row-major
  std::function<std::array<double, 3>(const std::array<double, 3>&)> nonlinear{};
  std::string colour_space = colour::kCameraRgb;  // what the output values are
  MosaicInterpolation interpolation = MosaicInterpolation::Bilinear;  // demosaic_to_colour's
  std::array<double, 3> apply(const std::array<double, 3>& camera) const;
};

// demosaic_merged and the colour map in one pass over the image (rows in parallel): the
// merged mosaic of a Bayer bracket to the R, G, B (with var.* and valid) a session stores,
// attributes paintlab.colour_space and paintlab.demosaic set. map.interpolation chooses the
// demosaicing. Gradient-corrected: a value is valid where every site its kernels read is; the
// variance through a matrix map is exact (the three channels of a pixel share sites, so their
// covariances enter); through a root-polynomial map the channels are taken as independent.
ExrImage demosaic_to_colour(const ExrImage& mosaic, const ColourMap& map);

// The colour map alone, for a camera that samples every channel at every pixel (a monochrome
// camera behind a filter wheel: one merged bracket per filter): three merged images (Y,
// var.Y, valid each; R, G, B in that order) to R, G, B, var.*, valid (valid where all three
// are), attribute paintlab.colour_space set. DataError for images of different sizes or
// without those planes.
ExrImage map_colour(const std::array<const ExrImage*, 3>& channels, const ColourMap& map);

// The same bilinear interpolation for a linear mosaic without variance (a linearised frame):
// three channels, camera RGB.
ImageF demosaic_bilinear(const ImageF& mosaic, dev::CfaPattern pattern);

// Luminance (R + 2G + B) / 4 at every pixel of a linear mosaic without demosaicing: the mosaic
// filtered by [1 2 1] x [1 2 1] / 16, which sees every 2x2 filter block's colours in those
// proportions wherever it is centred (weights renormalised at the image's border).
ImageF cfa_luminance(const ImageF& mosaic);

// A colour camera's gains (R, G, B relative to green) measured on a linear mosaic of a grey
// target (a chessboard, the white reference, a grey sphere under the LED): the median over the
// flat 2x2 blocks (all four sites between 20 % and 100 % of the image's 99th percentile, the
// two greens within 5 % of each other: no edge, no highlight's flank runs through them).
// Unset when fewer than `min_blocks` blocks qualify or their ratios scatter by more than 3 %
// (MAD): a dark image with a highlight, whose "flat" blocks are noise.
std::optional<std::array<double, 3>> grey_gains(const ImageF& mosaic, dev::CfaPattern pattern, int min_blocks = 200);

// The luminance of the mosaic with each colour's sites divided by its gain first: the mosaic
// of a grey scene becomes flat, so a small bright spot (a highlight) is not pulled towards the
// sites of the strongest colour.
ImageF balanced_luminance(const ImageF& mosaic, dev::CfaPattern pattern, const std::array<double, 3>& gains);

}  // namespace paintlab::acq
