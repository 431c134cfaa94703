#pragma once
// Colour science: CIE XYZ, CIELAB, CIEDE2000, chromatic adaptation and linear sRGB.
//
// The formulas are LittleCMS 2's (lcms2: cmsXYZ2Lab, cmsLab2XYZ, cmsCIE2000DeltaE,
// cmsAdaptToIlluminant with the Bradford transform), not ours: a well-kept library that
// colour-management software has relied on for twenty years. What is ours is the
// convention, the same everywhere in paintlab:
// - XYZ is relative: the perfect white diffuser under the illuminant has Y = 1 (a
//   reflectance factor, not a luminance in cd/m^2).
// - Linear sRGB is IEC 61966-2-1's: ITU-R BT.709 primaries, D65 white, the 2 deg observer;
//   its matrix is the standard's four-decimal one, and the D65 white used with it is that
//   matrix applied to (1, 1, 1) (0.9505, 1, 1.089), so that sRGB white is L* = 100, a* = b* = 0
//   exactly.
// - CIELAB of linear sRGB values is taken against that D65 white. L* may pass 100 (a
//   reflectance factor above 1 near the specular direction), as instrument values do.
#include <Eigen/Core>

namespace paintlab::colour {

// What the radiance values of an image, a session or a paint file are, as their files state
// it (session.json, EXR attribute paintlab.colour_space, the AxF-like /conventions).
inline constexpr const char* kCameraRgb = "linear camera RGB";  // the camera's own channels
inline constexpr const char* kLinearSrgb = "linear sRGB (D65)";  // after the colour calibration

using Xyz = Eigen::Vector3d;  // X, Y, Z with Y = 1 for the perfect white diffuser
using Rgb = Eigen::Vector3d;  // linear values (sRGB or a camera's), not gamma-encoded

struct Lab {
  double L = 0.0, a = 0.0, b = 0.0;
  double chroma() const;     // C*ab
  double hue_deg() const;    // h_ab in [0, 360)
  bool operator==(const Lab&) const = default;
};

// The white points: D50 is ICC's (lcms's cmsD50_XYZ: 0.9642, 1, 0.8249); D65 is sRGB's
// (see above).
const Xyz& d50();
const Xyz& d65();

Lab xyz_to_lab(const Xyz& xyz, const Xyz& white);
Xyz lab_to_xyz(const Lab& lab, const Xyz& white);

// A colour seen under `from_white` as it looks adapted to `to_white` (Bradford).
Xyz adapt(const Xyz& xyz, const Xyz& from_white, const Xyz& to_white);

// CIEDE2000 with the parametric factors kL = kC = kH = 1 (Sharma, Wu and Dalal 2005).
double delta_e_2000(const Lab& lab1, const Lab& lab2);
// With the parametric factors kL, kC, kH (> 1 makes that difference count less), as
// tolerance sets weight lightness against chroma and hue.
double delta_e_2000(const Lab& lab1, const Lab& lab2, double kL, double kC, double kH);

// Linear sRGB <-> XYZ (D65, Y = 1 for white).
const Eigen::Matrix3d& srgb_to_xyz_matrix();
const Eigen::Matrix3d& xyz_to_srgb_matrix();
inline Xyz srgb_to_xyz(const Rgb& rgb) { return srgb_to_xyz_matrix() * rgb; }
inline Rgb xyz_to_srgb(const Xyz& xyz) { return xyz_to_srgb_matrix() * xyz; }
inline Lab srgb_to_lab(const Rgb& rgb) { return xyz_to_lab(srgb_to_xyz(rgb), d65()); }

}  // namespace paintlab::colour
