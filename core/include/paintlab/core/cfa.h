#pragma once
// A Bayer colour filter array: which colour each pixel of a mosaic records. The camera
// (devices/camera.h) reports it, demosaicing (acquisition) reads it, and an HDR image keeps
// it in its "paintlab.cfa" attribute for the fit at the filter-array sites (fitting), so it
// lives here, below all three.
#include <string>

namespace paintlab {

// As GenICam names it: the colours of the 2x2 block at the image's top-left corner, row by
// row (RG: R G / G B). OpenCV names the same sensor after the block at row 1, column 1
// (GenICam RG is OpenCV's BayerBG): acq::demosaic translates.
enum class CfaPattern { None, RG, GR, GB, BG };

const char* to_string(CfaPattern p);  // "none", "RG", "GR", "GB", "BG"
// The arrangement named (to_string's names); DataError naming `where` and the names otherwise.
CfaPattern cfa_pattern_from_string(const std::string& name, const std::string& where);
// The colour (0 R, 1 G, 2 B) that pixel (x, y) of a `p` mosaic records; -1 for None.
int cfa_colour(CfaPattern p, int x, int y);

}  // namespace paintlab
