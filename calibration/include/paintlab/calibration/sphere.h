#pragma once
// The sphere's pose: its silhouette with sub-pixel edges, and from the known radius and the
// intrinsics the 3D centre in the camera frame. Written as calib/sphere.json.
//
// Geometry: a sphere of radius R whose centre lies at distance D along the unit direction d
// is seen inside the cone of rays r with angle(r, d) <= alpha, sin(alpha) = R / D. Its image
// is that cone cut by the image plane: an ellipse in the undistorted image (a circle only on
// the optical axis), then distorted by the lens. So the silhouette's edge points are turned
// into rays through the camera model (distortion included) and the cone (d, alpha) is fitted
// to them: centre = d R / sin(alpha). No circle or ellipse approximation enters the centre;
// a free ellipse fit in the undistorted image is reported as a shape diagnostic.
//
// Edges: around the silhouette, pixels are grouped in angular sectors and the radial
// profile of each sector is fitted with a blurred-edge model whose inside part follows the
// limb of a lit sphere: near the silhouette the cosine to the viewer grows like sqrt(t)
// (t = distance inside the edge), so the inside radiance is c0 + c1 sqrt(t) + c2 t. All of
// it is convolved with a Gaussian of width sigma (optics and pixel). A plain step model puts
// the edge of a frontally lit Lambertian sphere pixels inside; this model does not.
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/calibration/camera_model.h"
#include "paintlab/calibration/record.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/image.h"
#include "paintlab/core/json.h"

namespace paintlab::calib {

// One image of the sphere: linear values (any scale; raw values minus black level will do),
// 1 channel. Edges are taken where the sphere's limb is lit: with the LED beside the sphere
// (table angles near 90 and 270 deg) the left and right limbs are bright steps against the
// background. Several images (different LED angles) are combined.
struct SphereImage {
  std::string name;
  ImageF pixels;
};

struct SphereOptions {
  double radius_m = 0.0;            // the sphere's radius (caliper), required
  double sector_arc_px = 4.0;       // arc length of one angular sector
  double band_inside_px = 10.0;     // profile extent inside the coarse edge
  double band_outside_px = 7.0;     // and outside
  double min_snr = 12.0;            // edge contrast / residual noise for an edge point to count
  // Only step edges count: the jump at the edge must be at least this fraction of the
  // contrast 3 px inside. Where the limb is dark (light from behind the limb's normal, or
  // from the camera direction) the inside rises like sqrt(t) from nothing; such an edge
  // hangs on the shading model and is left out.
  double min_step_frac = 0.5;
  double outlier_sigmas = 4.0;      // edge points further from the fitted silhouette are dropped
  // The edge model includes the pixel's box (a pixel integrates over its square) besides the
  // optics' Gaussian; without it the Gaussian stands for both.
  bool pixel_box = true;
  // The inside's sqrt(t) onset is taken from the shading of the lit disc (one figure per
  // image, the physics of a lit Lambertian limb: limb_onset in sphere.cpp), not fitted per
  // sector, where it would also absorb any mismatch of the blur model and move the edge.
  bool limb_onset_from_shading = true;
  // Blur the processing added to the images (variance per axis, px^2; a colour camera's
  // luminance filter [1 2 1] x [1 2 1] / 16 adds 0.5): the focus figures (edge_sigma_px,
  // edge_width_px, psf_sigma_px) report the camera's, without it.
  double image_blur_var_px2 = 0.0;
  // Optional starting circle (pixels); radius 0: found by thresholding.
  Vec2 approx_centre_px = Vec2::Zero();
  double approx_radius_px = 0.0;

  void check() const;  // UsageError naming the first violated rule
};

struct EdgePoint {
  Vec2 px = Vec2::Zero();       // sub-pixel silhouette point (distorted image)
  double angle_rad = 0.0;       // polar angle around the image centre of the sphere
  double std_px = 0.0;          // 1-sigma from the profile fit
  double sigma_px = 0.0;        // edge blur as one Gaussian (optics and pixel box)
  double psf_sigma_px = 0.0;    // the optics' part (with SphereOptions::pixel_box; else = sigma_px)
  double step = 0.0;            // contrast of the edge step (inside at the edge - background)
  double residual_px = 0.0;     // distance to the fitted silhouette (signed, + outside)
  bool used = false;
  int image = 0;                // index of the SphereImage it came from
};

struct SphereFit {
  double radius_m = 0.0;
  Vec3 centre_cam_m = Vec3::Zero();
  Mat3 centre_cov_m2 = Mat3::Zero();  // covariance of the centre from the edge noise
  Vec3 axis = Vec3::UnitZ();          // unit direction to the centre
  double half_angle_rad = 0.0;        // cone half-angle alpha
  double rms_px = 0.0;                // edge points to the fitted sphere silhouette
  double max_px = 0.0;
  double ellipse_rms_px = 0.0;        // free ellipse (5 parameters) in the undistorted image
  Vec2 ellipse_centre_px = Vec2::Zero();  // of the free ellipse (undistorted pixels)
  Vec2 ellipse_axes_px = Vec2::Zero();    // semi-axes
  double ellipse_angle_deg = 0.0;
  double edge_sigma_px = std::numeric_limits<double>::quiet_NaN();  // median blur of strong edges
  double edge_width_px = std::numeric_limits<double>::quiet_NaN();  // 10-90 % rise = 2.563 sigma
  double psf_sigma_px = std::numeric_limits<double>::quiet_NaN();   // median optics blur without the pixel box
  int edges_used = 0;
  int edges_total = 0;
  double coverage = 0.0;              // fraction of the outline with used edge points
  std::vector<EdgePoint> edges;
  Provenance provenance;

  Vec3 centre_std_m() const;  // sqrt of the covariance diagonal
  // Pixel of the sphere centre's projection.
  Vec2 centre_px(const CameraModel& camera) const { return camera.project(centre_cam_m); }

  // Centre with its standard deviation (mm, camera frame), silhouette RMS, edge points used,
  // outline coverage and edge width, as the technician reads them.
  std::string describe() const;
  Json to_json() const;  // edges are summarised, not listed
  static SphereFit from_json(const Json& j, const std::string& where);
  void save(const std::filesystem::path& path) const;
  static SphereFit load(const std::filesystem::path& path);
};

// Fits the sphere. Throws CalibrationError when no sphere is found or too few edge points
// survive (the message says why: too dark, out of frame, no contrast).
SphereFit fit_sphere(const std::vector<SphereImage>& images, const CameraModel& camera,
                     const SphereOptions& options);

// The nearer intersection of the ray from the camera centre along unit `dir` with a
// sphere, or nothing when the ray misses.
std::optional<Vec3> intersect_sphere(const Vec3& dir, const Vec3& centre, double radius);

// Image of the sphere's silhouette: `n` points of the cone (distorted pixels), for drawing
// and for synthetic tests.
std::vector<Vec2> silhouette_points(const CameraModel& camera, const Vec3& centre_cam, double radius, int n);

// The limb profile function H(x) = integral_0^inf sqrt(u) phi(x - u) du (phi the standard
// normal density) and its derivative: a sqrt(t) onset blurred by a unit Gaussian.
double limb_profile(double x, double* derivative = nullptr);

}  // namespace paintlab::calib
