#include "paintlab/core/colour.h"

#include <Eigen/LU>
#include <cmath>
#include <lcms2.h>
#include <numbers>

namespace paintlab::colour {

namespace {

cmsCIEXYZ to_cms(const Xyz& v) { return cmsCIEXYZ{v.x(), v.y(), v.z()}; }
Xyz from_cms(const cmsCIEXYZ& v) { return Xyz(v.X, v.Y, v.Z); }
cmsCIELab to_cms(const Lab& v) { return cmsCIELab{v.L, v.a, v.b}; }

}  // namespace

double Lab::chroma() const { return std::hypot(a, b); }

double Lab::hue_deg() const {
  double h = std::atan2(b, a) * 180.0 / std::numbers::pi;
  if (h < 0.0) h += 360.0;
  return h;
}

const Xyz& d50() {
  static const Xyz white = from_cms(*cmsD50_XYZ());
  return white;
}

const Eigen::Matrix3d& srgb_to_xyz_matrix() {
  // IEC 61966-2-1:1999, the matrix from linear sRGB to CIE XYZ (D65).
  static const Eigen::Matrix3d m = (Eigen::Matrix3d() << 0.4124, 0.3576, 0.1805,  //
                                    0.2126, 0.7152, 0.0722,                       //
                                    0.0193, 0.1192, 0.9505)
                                       .finished();
  return m;
}

const Eigen::Matrix3d& xyz_to_srgb_matrix() {
  static const Eigen::Matrix3d m = srgb_to_xyz_matrix().inverse();
  return m;
}

const Xyz& d65() {
  static const Xyz white = srgb_to_xyz_matrix() * Xyz::Ones();
  return white;
}

Lab xyz_to_lab(const Xyz& xyz, const Xyz& white) {
  const cmsCIEXYZ w = to_cms(white), v = to_cms(xyz);
  cmsCIELab lab;
  cmsXYZ2Lab(&w, &lab, &v);
  return Lab{lab.L, lab.a, lab.b};
}

Xyz lab_to_xyz(const Lab& lab, const Xyz& white) {
  const cmsCIEXYZ w = to_cms(white);
  const cmsCIELab l = to_cms(lab);
  cmsCIEXYZ xyz;
  cmsLab2XYZ(&w, &xyz, &l);
  return from_cms(xyz);
}

Xyz adapt(const Xyz& xyz, const Xyz& from_white, const Xyz& to_white) {
  const cmsCIEXYZ from = to_cms(from_white), to = to_cms(to_white), v = to_cms(xyz);
  cmsCIEXYZ out;
  if (!cmsAdaptToIlluminant(&out, &from, &to, &v)) return Xyz::Constant(std::nan(""));
  return from_cms(out);
}

double delta_e_2000(const Lab& lab1, const Lab& lab2) { return delta_e_2000(lab1, lab2, 1.0, 1.0, 1.0); }

double delta_e_2000(const Lab& lab1, const Lab& lab2, double kL, double kC, double kH) {
  const cmsCIELab l1 = to_cms(lab1), l2 = to_cms(lab2);
  return cmsCIE2000DeltaE(&l1, &l2, kL, kC, kH);
}

}  // namespace paintlab::colour
