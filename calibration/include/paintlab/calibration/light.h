#pragma once
// The LED's position at every turntable angle, from the specular highlight on a glossy
// sphere (a mirror ball, a glossy black sphere or a clear-coated sample) seen at several
// table angles. Written as calib/light.json.
//
// Per image: the highlight is fitted with a glossy-lobe model on the sphere (sphere.h gives
// the sphere): for a candidate specular pixel p_s, the sphere point X_s and normal n_s give
// the mirror direction r_s; a pixel near it sees brightness A exp(-tan^2(theta_h) / m^2) /
// cos(theta_o) + background (Beckmann lobe; the 1/cos(theta_o) of the microfacet BRDF with
// the irradiance's cos(theta_i) cancelled), with theta_h between the pixel's normal and the
// half vector towards the LED, blurred by the camera's blur. Fitting p_s (and A, m, background) rather than taking the
// brightness centroid removes the shift of the peak that 1/cos(theta_o) causes (~0.04 deg
// for m = 0.03 at 120 deg). The LED then lies on the ray X_s + t r_s.
//
// Over all angles: the LED moves on a circle about the table axis, LED(a) = O + R (cos(a +
// a0) x + sin(a + a0) y) + h z in the rig frame: z = the table axis (up), O = the point of
// the axis at the height of the sphere centre, x = horizontal direction from the axis to the
// camera. Fitted: the axis direction (2), the axis position (2), the arm radius R, height h
// and zero offset a0, by least squares on the angles between the observed rays and the
// directions from X_s to LED(a). Residuals are reported in degrees.
//
// The arm radius is seen only through parallax (the highlights are within a sphere radius
// of the axis), and an off-centre axis looks like a change of radius unless the angles
// cover both sides of the camera: use table angles from about -150 to +150 deg. Measured
// with exact geometry and 0.003 deg of highlight noise: radius error 0.06 % for -150..150
// in 10 deg steps, 0.8 % for 0..150, 2.7 % for 0..100.
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/calibration/camera_model.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/sphere.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/image.h"
#include "paintlab/core/json.h"
#include "paintlab/core/rig.h"

namespace paintlab::calib {

// One image of the glossy sphere with the LED at a table angle: linear values, 1 channel.
struct HighlightImage {
  double table_angle_deg = 0.0;
  std::string name;
  ImageF pixels;
  double saturated_at = std::numeric_limits<double>::infinity();  // values >= this are clipped
};

struct Highlight {
  double table_angle_deg = 0.0;
  std::string name;
  bool found = false;
  std::string reason;           // why not found / not used
  Vec2 px = Vec2::Zero();       // specular pixel
  double std_px = 0.0;
  double roughness = 0.0;       // fitted lobe width m
  double blur_sigma_px = 0.0;   // the blur the lobe model was compared with (fitted with LightOptions::fit_blur)
  double blur_std_px = 0.0;     // its 1-sigma when fitted
  Vec3 point_cam = Vec3::Zero();   // sphere point X_s
  Vec3 normal_cam = Vec3::Zero();
  Vec3 mirror_dir = Vec3::Zero();  // unit r_s: the LED lies on X_s + t r_s
  double residual_deg = 0.0;    // angle between r_s and the model's direction to the LED
  double azimuth_error_deg = 0.0;  // signed part of it along the circle
  bool used = false;
};

// The LED circle about the table axis, in the camera frame, and the rig frame it defines.
struct LightModel {
  Vec3 axis_cam = Vec3(0, -1, 0);     // z of the rig frame (up)
  Vec3 origin_cam = Vec3::Zero();     // O: on the axis at the sphere centre's height
  double arm_radius_m = 0.0;
  double arm_height_m = 0.0;          // LED height above O (above the sphere centre)
  double zero_deg = 0.0;              // LED azimuth at table angle 0 (from the camera direction)
  // LED emission I(theta) = I0 cos^n(theta) about its axis, which points at `aim` (O unless
  // told otherwise); n from the scale calibration (0 until then: isotropic).
  double profile_exponent = 0.0;

  // Rig frame: origin O, z = axis, x towards the camera.
  Rigid3 cam_from_rig() const;
  Vec3 led_position_cam(double table_angle_deg) const;
  Vec3 led_position_rig(double table_angle_deg) const;
  // Unit LED axis in the camera frame at a table angle (towards O).
  Vec3 led_axis_cam(double table_angle_deg) const;
  // Relative radiant intensity towards a camera-frame point: cos^n of the off-axis angle.
  double led_profile(double table_angle_deg, const Vec3& point_cam) const;
  // Irradiance (per unit on-axis LED intensity, 1/m^2) on a surface at point_cam with unit
  // normal_cam: profile cos(theta_i) / d^2, 0 when the light is behind the surface.
  double irradiance(double table_angle_deg, const Vec3& point_cam, const Vec3& normal_cam) const;

  Json to_json() const;
  static LightModel from_json(const Json& j, const std::string& where);
};

struct LightOptions {
  double half_window_px = 0.0;  // highlight fit window; 0: automatic (from the lobe width)
  // Gaussian blur of the optics (and pixel) applied to the lobe model before it is compared
  // with the image; < 0: the sphere calibration's edge blur (SphereFit::edge_sigma_px).
  // Near the limb the highlight is foreshortened to a few pixels and the blur would
  // otherwise shift it (0.6 deg at a table angle of 150 deg with a 0.5 px blur).
  double blur_sigma_px = -1.0;
  // Fit the blur with each lobe (start: blur_sigma_px or the sphere's; bounded to
  // [0.1, max(1, 2 x start)] px). calibrate_light does this in a first pass when
  // blur_sigma_px < 0 and common_blur is set.
  bool fit_blur = false;
  // calibrate_light: the blur of the highlights from the highlights themselves: each lobe is
  // fitted with a free blur, their inverse-variance weighted mean is the optics' blur, and
  // every lobe is fitted again with it. The silhouette's edge blur is not the same figure:
  // it includes the pixel's box, which a renderer that shades pixels at their centres does
  // not apply to the highlight (and a sensor does); a wrong blur moves the fitted specular
  // points near the limb and so the arm radius (docs/calibration.md).
  bool common_blur = true;
  double min_snr = 20.0;        // highlight peak / background noise
  double max_view_angle_deg = 78.0;  // highlights closer to the limb are not used
  // Nor highlights fewer pixels inside the silhouette than this; 0: the blur kernel's width
  // (2 ceil(3 sigma) + 1: 5 px at 0.5 px, 7 px while the blur is fitted).
  double min_limb_distance_px = 0.0;
  double outlier_deg = 0.0;     // 0: automatic (5 x robust RMS, at least 0.02 deg)
  void check() const;
};

struct LightCalibration {
  LightModel model;
  std::vector<Highlight> highlights;  // every input image, in input order
  double rms_deg = 0.0;               // over used highlights
  double max_deg = 0.0;
  int used = 0;
  // 1-sigma of the fitted parameters.
  double arm_radius_std_m = 0.0, arm_height_std_m = 0.0, zero_std_deg = 0.0, axis_std_deg = 0.0;
  // The blur the highlights were fitted with (Gaussian sigma, px) and where it came from:
  // "highlights" (fitted from them, with its 1-sigma), "sphere" (the silhouette's edge blur)
  // or "given" (LightOptions::blur_sigma_px). The live check fits highlights with it.
  double blur_sigma_px = 0.0, blur_std_px = 0.0;
  std::string blur_source;
  Provenance provenance;

  // Highlights used, residuals, the arm with its standard deviations, the blur and where it
  // came from, and each highlight left out with the reason (several lines).
  std::string describe() const;
  Json to_json() const;
  static LightCalibration from_json(const Json& j, const std::string& where);
  void save(const std::filesystem::path& path) const;
  static LightCalibration load(const std::filesystem::path& path);
};

// Finds the specular highlight of one image on the fitted sphere.
Highlight find_highlight(const HighlightImage& image, const CameraModel& camera, const SphereFit& sphere,
                         const RigGeometry& nominal, const LightOptions& options = {});

// Fits the LED circle to highlights found in images at >= 4 table angles (nominal geometry:
// the starting point). Throws CalibrationError naming the images that failed and why
// when fewer than 4 highlights remain.
LightCalibration calibrate_light(const std::vector<HighlightImage>& images, const CameraModel& camera,
                                 const SphereFit& sphere, const RigGeometry& nominal,
                                 const LightOptions& options = {});

// Sets h.residual_deg (angle between the observed mirror ray and the model's LED) and
// h.azimuth_error_deg (the observed ray met with the LED circle, azimuth against the model).
void highlight_residual(const LightModel& model, Highlight* h);

// The same from highlights already found (their table angle, point, mirror direction).
LightCalibration fit_light_model(std::vector<Highlight> highlights, const SphereFit& sphere,
                                 const RigGeometry& nominal, const LightOptions& options = {});

}  // namespace paintlab::calib
