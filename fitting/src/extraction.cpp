#include "paintlab/fitting/extraction.h"

#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fmt/format.h>
#include <limits>

#include "paintlab/brdf/rusinkiewicz.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/sphere.h"
#include "paintlab/core/cfa.h"
#include "paintlab/core/colour.h"
#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/log.h"
#include "paintlab/core/progress.h"

namespace paintlab::fit {

void ExtractionOptions::check() const {
  auto fail = [](const char* key, double v, const char* rule) {
    throw OptionError(std::string("ExtractionOptions::") + key, fmt::format("{}", v), rule);
  };
  if (!(margin_px >= 0.0)) fail("margin_px", margin_px, ">= 0");
  if (!(min_cos >= 0.0 && min_cos < 1.0)) fail("min_cos", min_cos, "in [0, 1)");
  if (!(min_normal_up >= -1.0 && min_normal_up < 1.0)) fail("min_normal_up", min_normal_up, "in [-1, 1)");
  if (threads < 0) fail("threads", threads, ">= 0");
  if (images_in_flight < 0) fail("images_in_flight", images_in_flight, ">= 0");
  if (valid_margin_px < 0 || valid_margin_px > 10) fail("valid_margin_px", valid_margin_px, "in [0, 10]");
  if (!(blur_sigma_px <= 10.0)) fail("blur_sigma_px", blur_sigma_px, "<= 10 (< 0: the calibration's)");
  if (!(max_blur_correction > 0.0 && max_blur_correction <= 1.0))
    fail("max_blur_correction", max_blur_correction, "in (0, 1]");
  // The local variance compares a pixel with its four neighbours, which at a filter-array
  // site are the other colours (interpolated values, the very thing cfa_sites keeps out).
  if (cfa_sites && variance == VarianceModel::Local)
    throw OptionError("ExtractionOptions::cfa_sites", "true",
                      "not with the local variance model: a site's neighbours are other colours");
}

namespace {

// The radiance channels of an HDR image (hdr_merge.h): mono "Y" (in all three) or "R", "G",
// "B", their "var.*" variances when all are there, and "valid".
struct HdrChannels {
  std::array<const ImageF*, 3> value{};
  std::array<const ImageF*, 3> variance{};
  bool with_variance = false;
  const ImageF* valid = nullptr;
  bool mono() const { return value[0] == value[1]; }
};

HdrChannels hdr_channels(const ExrImage& hdr, const std::string& source) {
  HdrChannels ch;
  if (const ImageF* y = hdr.find("Y")) {
    ch.value = {y, y, y};
    const ImageF* v = hdr.find("var.Y");
    ch.variance = {v, v, v};
  } else if (hdr.find("R") && hdr.find("G") && hdr.find("B")) {
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c) {
      ch.value[static_cast<std::size_t>(c)] = hdr.find(names[c]);
      ch.variance[static_cast<std::size_t>(c)] = hdr.find(std::string("var.") + names[c]);
    }
  } else {
    throw DataError(fmt::format("{}: no radiance channels (expected Y, or R, G and B)", source));
  }
  ch.with_variance = ch.variance[0] && ch.variance[1] && ch.variance[2];
  ch.valid = hdr.find("valid");
  return ch;
}

// Whether a pixel of a width x height image has an invalid pixel ("valid" channel) within
// vm pixels (a square), or is closer than vm to the border.
bool near_invalid_pixel(const ImageF* valid, std::size_t i, int width, int height, int vm) {
  if (!valid || vm <= 0) return false;
  const int x = static_cast<int>(i % static_cast<std::size_t>(width)), y = static_cast<int>(i / static_cast<std::size_t>(width));
  if (x < vm || y < vm || x + vm >= width || y + vm >= height) return true;
  for (int dy = -vm; dy <= vm; ++dy) {
    const float* row = valid->data() + static_cast<std::size_t>(y + dy) * static_cast<std::size_t>(width);
    for (int dx = -vm; dx <= vm; ++dx)
      if (!(row[x + dx] > 0.5f)) return true;
  }
  return false;
}

// A sphere pixel's measurement and directions, when it passes the rules every extracted
// pixel passes (extraction.h): valid in the merge, a finite value and variance, lit and seen
// off the horizon, no invalid pixel within valid_margin_px. Otherwise the rule it failed is
// counted in `st` and the result is false.
struct Screened {
  float rgb[3], var[3];
  Vec3 normal, wi, wo;
  double irradiance;
};
template <class ValueAt, class VarianceAt>
bool screen_pixel(std::size_t i, const Eigen::Vector3f& point, const Eigen::Vector3f& normal,
                  const Eigen::Vector3f& to_camera, const ImageF* valid, ValueAt value_at, VarianceAt variance_at,
                  bool with_variance, const calib::LightModel& light, const Vec3& led, double table_angle_deg,
                  const ExtractionOptions& o, int width, int height, ExtractionStats& st, Screened* out) {
  if (valid && !(valid->data()[i] > 0.5f)) {
    ++st.invalid;
    return false;
  }
  bool finite = true;
  for (int c = 0; c < 3; ++c) {
    out->rgb[c] = value_at(c, i);
    out->var[c] = with_variance ? variance_at(c, i) : 0.0f;
    finite = finite && std::isfinite(out->rgb[c]) && std::isfinite(out->var[c]);
  }
  if (!finite) {
    ++st.non_finite;
    return false;
  }
  const Vec3 p = point.cast<double>();
  out->normal = normal.cast<double>();
  out->wo = to_camera.cast<double>();
  out->wi = (led - p).normalized();
  out->irradiance = light.irradiance(table_angle_deg, p, out->normal);
  if (out->normal.dot(out->wi) < o.min_cos || out->normal.dot(out->wo) < o.min_cos || !(out->irradiance > 0.0)) {
    ++st.grazing;
    return false;
  }
  if (near_invalid_pixel(valid, i, width, height, o.valid_margin_px)) {
    ++st.near_invalid;
    return false;
  }
  return true;
}

// The camera RGB of a site table from the stored colour (value) and its variance: v = A s
// with A = site_to_srgb; for the variance the demosaiced channels of a pixel are taken as
// independent (exact for bilinear demosaicing: they come from different sites), so
// var(s) = (A o A)^-1 var(v) (o: element-wise product).
struct SiteInverse {
  Eigen::Matrix3d value = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d variance = Eigen::Matrix3d::Identity();
};

}  // namespace

constexpr EnumNames<VarianceModel, 2> kVarianceNames{{{VarianceModel::Hdr, "hdr"}, {VarianceModel::Local, "local"}}};

const char* to_string(VarianceModel v) { return enum_name(kVarianceNames, v); }

VarianceModel variance_model_from_string(std::string_view s, std::string_view where) {
  return enum_from_name(kVarianceNames, s, "variance model", where);
}

void ExtractionStats::add(const ExtractionStats& o) {
  images += o.images;
  sphere_pixels += o.sphere_pixels;
  samples += o.samples;
  invalid += o.invalid;
  non_finite += o.non_finite;
  grazing += o.grazing;
  near_invalid += o.near_invalid;
  blurred += o.blurred;
  deblurred += o.deblurred;
  unresolved += o.unresolved;
}

Json ExtractionStats::to_json() const {
  return {{"images", images},   {"sphere_pixels", sphere_pixels}, {"samples", samples},
          {"invalid", invalid}, {"non_finite", non_finite},       {"grazing", grazing},
          {"near_invalid", near_invalid}, {"blurred", blurred}, {"deblurred", deblurred},
          {"unresolved", unresolved}};
}

std::string ExtractionStats::describe(std::size_t measured_bins) const {
  return fmt::format("{} images: {} samples ({} invalid, {} grazing, {} next to invalid, {} blurred pixels skipped; {} "
                     "sharpened, {} too sharp to correct) in {} measured bins",
                     images, samples, invalid, grazing, near_invalid, blurred, deblurred, unresolved, measured_bins);
}

double blur_sigma_to_correct(const ExtractionOptions& options, const calib::RigCalibration& calibration) {
  if (options.blur_sigma_px >= 0.0) return options.blur_sigma_px;
  const auto& light = calibration.light();
  return light && std::isfinite(light->blur_sigma_px) ? std::max(0.0, light->blur_sigma_px) : 0.0;
}

SphereSampler::SphereSampler(const calib::RigCalibration& calibration, const ExtractionOptions& options)
    : cal_(&calibration), options_(options) {
  options_.check();
  calibration.require({calib::kCameraFile, calib::kSphereFile, calib::kLightFile, calib::kScaleFile});
  const calib::CameraModel& camera = calibration.camera();
  width_ = camera.width_px;
  height_ = camera.height_px;
  blur_sigma_px_ = blur_sigma_to_correct(options_, calibration);
  if (options_.cfa_sites && calibration.colour()) {
    // What measure stored: linear sRGB = M_bal (balance .* camera) (acq::prepare_colour).
    const std::optional<Eigen::Matrix3d> m = calibration.colour()->balanced_srgb_matrix();
    const std::optional<std::array<double, 3>> balance = calibration.scale()->white_balance();
    if (m && balance) site_to_srgb_ = *m * Eigen::Vector3d((*balance)[0], (*balance)[1], (*balance)[2]).asDiagonal();
  }
  const calib::SphereFit& sphere = *calibration.sphere();
  const Mat3 rig_from_cam = calibration.cam_from_rig().inverse().matrix();

  // The silhouette's bounding box (plus the margin and a pixel) limits the search.
  double x0 = width_, y0 = height_, x1 = 0, y1 = 0;
  for (const Vec2& p : calib::silhouette_points(camera, sphere.centre_cam_m, sphere.radius_m, 360)) {
    x0 = std::min(x0, p.x());
    y0 = std::min(y0, p.y());
    x1 = std::max(x1, p.x());
    y1 = std::max(y1, p.y());
  }
  const int pad = static_cast<int>(std::ceil(options_.margin_px)) + 2;
  const int bx0 = std::clamp(static_cast<int>(std::floor(x0)) - pad, 0, width_ - 1);
  const int by0 = std::clamp(static_cast<int>(std::floor(y0)) - pad, 0, height_ - 1);
  const int bx1 = std::clamp(static_cast<int>(std::ceil(x1)) + pad, 0, width_ - 1);
  const int by1 = std::clamp(static_cast<int>(std::ceil(y1)) + pad, 0, height_ - 1);
  if (bx1 < bx0 || by1 < by0) throw CalibrationError("the calibrated sphere is not inside the camera image");

  const double m = options_.margin_px;
  std::vector<std::vector<Pixel>> rows(static_cast<std::size_t>(by1 - by0 + 1));
  tbb::parallel_for(by0, by1 + 1, [&](int y) {
    auto& row = rows[static_cast<std::size_t>(y - by0)];
    for (int x = bx0; x <= bx1; ++x) {
      const Vec2 px(x, y);
      const auto sp = calibration.sphere_point_at(px);
      if (!sp) continue;
      if (m > 0.0 && (!calibration.sphere_point_at(px + Vec2(m, 0)) || !calibration.sphere_point_at(px - Vec2(m, 0)) ||
                      !calibration.sphere_point_at(px + Vec2(0, m)) || !calibration.sphere_point_at(px - Vec2(0, m))))
        continue;
      if ((rig_from_cam * sp->normal).z() <= options_.min_normal_up) continue;
      row.push_back({static_cast<std::uint32_t>(y) * static_cast<std::uint32_t>(width_) + static_cast<std::uint32_t>(x),
                     sp->point.cast<float>(), sp->normal.cast<float>(), sp->to_camera.cast<float>()});
    }
  });
  for (const auto& row : rows) pixels_.insert(pixels_.end(), row.begin(), row.end());
  if (pixels_.empty()) throw CalibrationError("no pixel of the calibrated sphere's upper half is in the image");
}

ExtractionStats SphereSampler::extract(const ExrImage& hdr, double table_angle_deg, SampleBatch& out,
                                       const std::string& source) const {
  if (options_.cfa_sites)
    throw DataError(fmt::format("{}: extraction at the filter-array sites fills one table per colour "
                                "(extract_sites)", source));
  return extract_into(hdr, table_angle_deg, &out, nullptr, source);
}

ExtractionStats SphereSampler::extract_sites(const ExrImage& hdr, double table_angle_deg,
                                             std::array<SampleBatch, 3>& out, const std::string& source) const {
  if (!options_.cfa_sites)
    throw DataError(fmt::format("{}: extraction at the filter-array sites needs ExtractionOptions::cfa_sites", source));
  return extract_into(hdr, table_angle_deg, nullptr, &out, source);
}

ExtractionStats SphereSampler::for_each_value(const ExrImage& hdr, double table_angle_deg,
                                              const std::function<void(const PixelValue&)>& f,
                                              const std::string& source) const {
  if (hdr.width != width_ || hdr.height != height_)
    throw DataError(fmt::format("{}: {} x {} pixels, but the calibrated camera has {} x {}", source, hdr.width,
                                hdr.height, width_, height_));
  const HdrChannels ch = hdr_channels(hdr, source);
  const calib::LightModel light = cal_->light_model();
  const calib::ScaleCalibration& scale = *cal_->scale();
  const Vec3 led = light.led_position_cam(table_angle_deg);
  tbb::combinable<ExtractionStats> counts;
  auto value_at = [&](int c, std::size_t i) { return ch.value[static_cast<std::size_t>(c)]->data()[i]; };
  auto variance_at = [&](int c, std::size_t i) { return ch.variance[static_cast<std::size_t>(c)]->data()[i]; };
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pixels_.size(), 4096), [&](const auto& r) {
    ExtractionStats& st = counts.local();
    for (std::size_t k = r.begin(); k != r.end(); ++k) {
      const Pixel& p = pixels_[k];
      ++st.sphere_pixels;
      Screened sc;
      if (!screen_pixel(p.index, p.point, p.normal, p.to_camera, ch.valid, value_at, variance_at, ch.with_variance,
                        light, led, table_angle_deg, options_, width_, height_, st, &sc))
        continue;
      PixelValue v;
      v.pixel = static_cast<std::uint32_t>(k);
      for (std::size_t c = 0; c < 3; ++c) {
        v.rgb[c] = sc.rgb[c];
        v.var[c] = sc.var[c];
      }
      const Vec3& n = sc.normal;
      const Vec3& wi = sc.wi;
      const Vec3& wo = sc.wo;
      const double e = sc.irradiance;
      const double to_brdf = scale.brdf(1.0, e);
      for (std::size_t c = 0; c < 3; ++c) {
        v.rgb[c] *= to_brdf;
        v.var[c] *= to_brdf * to_brdf;
      }
      const Mat3 frame = frame_from_normal(n);
      v.wi = frame.transpose() * wi;
      v.wo = frame.transpose() * wo;
      v.h_cam = (wi + wo).normalized();
      ++st.samples;
      f(v);
    }
  });
  ExtractionStats total;
  total.images = 1;
  counts.combine_each([&](const ExtractionStats& s) { total.add(s); });
  return total;
}

ExtractionStats SphereSampler::extract_into(const ExrImage& hdr, double table_angle_deg, SampleBatch* out_one,
                                            std::array<SampleBatch, 3>* sites, const std::string& source) const {
  if (hdr.width != width_ || hdr.height != height_)
    throw DataError(fmt::format("{}: {} x {} pixels, but the calibrated camera has {} x {}", source, hdr.width,
                                hdr.height, width_, height_));
  const HdrChannels channels = hdr_channels(hdr, source);
  const ImageF* const* value = channels.value.data();
  const ImageF* const* variance = channels.variance.data();
  const bool with_variance = channels.with_variance;
  const ImageF* valid = channels.valid;
  CfaPattern pattern = CfaPattern::None;
  SiteInverse inverse;
  if (sites) {
    const auto attr = [&](const char* key) {
      const auto it = hdr.attributes.find(key);
      return it == hdr.attributes.end() ? std::string() : it->second;
    };
    const std::string cfa = attr("paintlab.cfa");
    for (const CfaPattern p : {CfaPattern::RG, CfaPattern::GR, CfaPattern::GB, CfaPattern::BG})
      if (cfa == to_string(p)) pattern = p;
    if (pattern == CfaPattern::None || value[0] == value[1])
      throw DataError(fmt::format("{}: not the colour image of a Bayer camera (no paintlab.cfa attribute naming RG, "
                                  "GR, GB or BG): only such sessions are fitted at their filter-array sites",
                                  source));
    const std::string space = attr("paintlab.colour_space");
    if (space != colour::kCameraRgb) {
      if (!site_to_srgb_)
        throw DataError(fmt::format("{}: in {}, which only the 3x3 matrix colour calibration maps back to camera RGB "
                                    "at the filter-array sites; the calibration has {}",
                                    source, space.empty() ? "an unstated colour space" : space,
                                    !cal_->colour()                                ? "no colour.json"
                                    : !cal_->colour()->balanced_srgb_matrix()      ? "a root-polynomial model"
                                                                                   : "no per-channel scale (scale_rgb) "
                                                                                     "to undo the white balance with"));
      inverse.value = site_to_srgb_->inverse();
      inverse.variance = site_to_srgb_->cwiseProduct(*site_to_srgb_).inverse();
    }
  }
  // At the filter-array sites: every pixel's own colour in camera RGB (its "mosaic" value)
  // and its variance, so the lens-blur correction below can look at the nearest sites of the
  // same colour.
  std::vector<float> mosaic, mosaic_var;
  auto site_colour = [&](std::size_t i) {
    const std::size_t x = i % static_cast<std::size_t>(width_), y = i / static_cast<std::size_t>(width_);
    return cfa_colour(pattern, static_cast<int>(x), static_cast<int>(y));
  };
  if (sites) {
    const std::size_t n = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
    mosaic.resize(n);
    mosaic_var.assign(n, 0.0f);
    tbb::parallel_for(0, height_, [&](int y) {
      for (int x = 0; x < width_; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(x);
        const int c = site_colour(i);
        const Eigen::Vector3d rgb(value[0]->data()[i], value[1]->data()[i], value[2]->data()[i]);
        mosaic[i] = static_cast<float>(inverse.value.row(c).dot(rgb));
        if (with_variance) {
          const Eigen::Vector3d var(variance[0]->data()[i], variance[1]->data()[i], variance[2]->data()[i]);
          // Rounding can take the solved variance of a noiseless value a little below zero; a
          // non-finite one stays non-finite (the pixel is then left out as such).
          const double u = inverse.variance.row(c).dot(var);
          mosaic_var[i] = static_cast<float>(u < 0.0 ? 0.0 : u);
        }
      }
    });
  }
  auto value_at = [&](int c, std::size_t i) { return sites ? mosaic[i] : value[c]->data()[i]; };
  auto variance_at = [&](int c, std::size_t i) { return sites ? mosaic_var[i] : variance[c]->data()[i]; };

  const calib::LightModel light = cal_->light_model();
  const calib::ScaleCalibration& scale = *cal_->scale();
  const Vec3 led = light.led_position_cam(table_angle_deg);
  ExtractionStats st;
  st.images = 1;

  // Pass 1: the BRDF value of every usable sphere pixel, also into a frame-sized buffer
  // (NaN elsewhere) so pass 2 can look at a pixel's neighbours.
  struct Value {
    std::uint32_t pixel;  // into pixels_
    float rgb[3];
    float var[3];
    brdf::HalfDiff hd;
  };
  // Lens blur, undone to first order where it matters (extraction.h): I - k lap(I) with
  // k = sigma^2 / 2, applied to a channel when the correction exceeds twice its standard
  // deviation (elsewhere it would only add noise). Where the correction is more than
  // max_blur_correction of the corrected value beyond three of them in a channel, the
  // expansion does not hold (structure as small as the blur: the far flanks of a highlight,
  // a highlight a few pixels across, a glint) and the pixel is kept as measured, or left
  // out with skip_too_sharp; where a neighbour is missing or may be saturated (its spill
  // unknown), it is left out.
  const double blur_k = 0.5 * blur_sigma_px_ * blur_sigma_px_;
  enum class Deblur { Unchanged, Changed, Unresolved, Rejected, NonFinite };
  auto deblur = [&](std::size_t i, float* rgb, float* var) {
    const std::size_t w = static_cast<std::size_t>(width_);
    const std::size_t x = i % w, y = i / w;
    // The four nearest pixels that measured the same colour, and the squared spacing h2 of
    // their Laplacian, (sum - 4 I) / h2: the four neighbours (h2 1), or at the filter-array
    // sites the sites of the pixel's own colour, two pixels away for red and blue (h2 4), the
    // diagonal greens for green (h2 2).
    const bool green = sites && site_colour(i) == 1;
    const std::size_t d = sites && !green ? 2 : 1;
    const double h2 = !sites ? 1.0 : green ? 2.0 : 4.0;
    if (x < d || y < d || x + d >= w || y + d >= static_cast<std::size_t>(height_)) return Deblur::Rejected;
    const std::array<std::size_t, 4> nb = green ? std::array<std::size_t, 4>{i - w - 1, i - w + 1, i + w - 1, i + w + 1}
                                                : std::array<std::size_t, 4>{i - d, i + d, i - d * w, i + d * w};
    // An invalid neighbour holds a bound (hdr_merge.h): one at most this pixel's value is
    // a dark one (below the noise floor), taken as a value uniform between 0 and it; a
    // brighter one may be saturated, and its spill is unknown.
    bool dark[4] = {false, false, false, false};
    if (valid)
      for (int q = 0; q < 4; ++q) {
        if (valid->data()[nb[q]] > 0.5f) continue;
        for (int c = 0; c < 3; ++c) {
          const float u = value_at(c, nb[q]);
          if (!(std::isfinite(u) && u <= rgb[c])) return Deblur::Rejected;
        }
        dark[q] = true;
      }
    const double k = blur_k / h2;
    float out[3], out_var[3];
    bool changed = false;
    for (int c = 0; c < 3; ++c) {
      double sum = 0.0, var_sum = 0.0;
      for (int q = 0; q < 4; ++q) {
        const double u = value_at(c, nb[q]);
        sum += u;
        if (dark[q]) var_sum += u * u / 12.0;
        else if (with_variance) var_sum += variance_at(c, nb[q]);
      }
      if (!std::isfinite(sum) || !std::isfinite(var_sum)) return Deblur::NonFinite;
      const double correction = k * (sum - 4.0 * rgb[c]);
      const double sd = k * std::sqrt(var_sum + 16.0 * var[c]);
      const double corrected = rgb[c] - correction;
      if (std::abs(correction) > options_.max_blur_correction * std::abs(corrected) + 3.0 * sd)
        return options_.skip_too_sharp ? Deblur::Rejected : Deblur::Unresolved;
      out[c] = rgb[c];
      out_var[c] = var[c];
      if (std::abs(correction) > 2.0 * sd) {
        out[c] = static_cast<float>(corrected);
        out_var[c] = static_cast<float>((1.0 + 4.0 * k) * (1.0 + 4.0 * k) * var[c] + k * k * var_sum);
        changed = true;
      }
    }
    for (int c = 0; c < 3; ++c) {
      rgb[c] = out[c];
      var[c] = out_var[c];
    }
    return changed ? Deblur::Changed : Deblur::Unchanged;
  };
  // Censoring at the noise floor and spill from saturated pixels: next to pixels the merge
  // marked invalid, a valid pixel is there because its noise lifted it over the floor (a
  // bright bias at the terminator), or it holds light spilled from a saturated neighbour.
  std::vector<Value> values;
  values.reserve(pixels_.size());
  const bool local = options_.variance == VarianceModel::Local;
  std::vector<float> frame;
  if (local) frame.assign(3 * static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_),
                          std::numeric_limits<float>::quiet_NaN());
  for (std::size_t k = 0; k < pixels_.size(); ++k) {
    const Pixel& p = pixels_[k];
    ++st.sphere_pixels;
    const std::size_t i = p.index;
    Screened sc;
    if (!screen_pixel(i, p.point, p.normal, p.to_camera, valid, value_at, variance_at, with_variance, light, led,
                      table_angle_deg, options_, width_, height_, st, &sc))
      continue;
    Value v;
    v.pixel = static_cast<std::uint32_t>(k);
    std::copy(sc.rgb, sc.rgb + 3, v.rgb);
    std::copy(sc.var, sc.var + 3, v.var);
    const Vec3& n = sc.normal;
    const Vec3& wi = sc.wi;
    const Vec3& wo = sc.wo;
    const double e = sc.irradiance;
    if (blur_k > 0.0) {
      const Deblur d = deblur(i, v.rgb, v.var);
      if (d == Deblur::Rejected) {
        ++st.blurred;
        continue;
      }
      if (d == Deblur::NonFinite) {
        ++st.non_finite;
        continue;
      }
      if (d == Deblur::Changed) ++st.deblurred;
      if (d == Deblur::Unresolved) ++st.unresolved;
    }
    const double to_brdf = scale.brdf(1.0, e);  // 1 / (scale E)
    for (int c = 0; c < 3; ++c) {
      v.rgb[c] = static_cast<float>(v.rgb[c] * to_brdf);
      v.var[c] = static_cast<float>(v.var[c] * to_brdf * to_brdf);
      if (local) frame[3 * i + c] = v.rgb[c];
    }
    const Mat3 frame_n = frame_from_normal(n);
    v.hd = brdf::half_diff_from_directions(frame_n.transpose() * wi, frame_n.transpose() * wo);
    values.push_back(v);
  }

  // Pass 2: the samples. With the local variance model, a sample's variance is
  // (v[-1] - 2 v + v[+1])^2 / 6 averaged over the horizontal and vertical neighbours that
  // exist: for independent pixels its expectation is the pixel's whole stochastic
  // variance, noise and sparkle, while the BRDF's smooth change across the image cancels
  // to first order. Without neighbours, the HDR variance.
  const bool keep_variance = with_variance || local;
  auto check_batch = [&](SampleBatch& batch, std::size_t expected) {
    batch.reserve(batch.size() + expected, keep_variance);
    if (!batch.empty() && batch.has_variance() != keep_variance)
      throw DataError(fmt::format("{}: has{} variance channels, unlike the images before it", source,
                                  keep_variance ? "" : " no"));
  };
  if (out_one) check_batch(*out_one, values.size());
  if (sites)
    for (int c = 0; c < 3; ++c) check_batch((*sites)[static_cast<std::size_t>(c)], values.size() / (c == 1 ? 2 : 4));
  for (Value& v : values) {
    if (local) {
      const std::size_t i = pixels_[v.pixel].index;
      const int x = static_cast<int>(i % static_cast<std::size_t>(width_)), y = static_cast<int>(i / static_cast<std::size_t>(width_));
      double acc[3] = {0, 0, 0};
      int used = 0;
      auto second_difference = [&](std::ptrdiff_t step, bool inside) {
        if (!inside) return;
        const float* a = &frame[3 * (i - step)];
        const float* b = &frame[3 * (i + step)];
        if (!std::isfinite(a[0]) || !std::isfinite(b[0])) return;
        for (int c = 0; c < 3; ++c) {
          const double d = static_cast<double>(a[c]) - 2.0 * v.rgb[c] + b[c];
          acc[c] += d * d / 6.0;
        }
        ++used;
      };
      second_difference(1, x > 0 && x + 1 < width_);
      second_difference(width_, y > 0 && y + 1 < height_);
      if (used > 0)
        for (int c = 0; c < 3; ++c) v.var[c] = static_cast<float>(acc[c] / used);
    }
    // At the sites the value (in all three channels) is the pixel's own colour's: it goes to
    // that colour's table.
    SampleBatch* out = sites ? &(*sites)[static_cast<std::size_t>(site_colour(pixels_[v.pixel].index))] : out_one;
    if (keep_variance)
      out->push_back(v.hd.theta_h, v.hd.theta_d, v.hd.phi_d, v.rgb, v.var);
    else
      out->push_back(v.hd.theta_h, v.hd.theta_d, v.hd.phi_d, v.rgb[0], v.rgb[1], v.rgb[2]);
    ++st.samples;
  }
  return st;
}

namespace {

void log_extraction(const SphereSampler& sampler, const ExtractionOptions& extraction);

// Reads, extracts and bins the groups' frames in a bounded pipeline (extraction.h), group
// after group, each with its own sampler, into one accumulator, or into three by
// filter-array site (extraction.cfa_sites).
std::vector<BinnedTable> extract_and_bin(const std::vector<CalibratedFrames>& groups,
                                         const std::vector<SphereSampler>& samplers,
                                         const ExtractionOptions& extraction, const BinningOptions& binning,
                                         ExtractionStats* stats) {
  const bool by_site = extraction.cfa_sites;
  std::vector<BinAccumulator> acc;
  for (int k = 0; k < (by_site ? 3 : 1); ++k) acc.emplace_back(binning);
  const int threads = extraction.threads > 0 ? extraction.threads : tbb::this_task_arena::max_concurrency();
  const std::size_t in_flight =
      static_cast<std::size_t>(extraction.images_in_flight > 0 ? extraction.images_in_flight : 2 * threads);
  // Every frame as (group, frame), in order.
  std::vector<std::pair<std::size_t, std::size_t>> order;
  for (std::size_t g = 0; g < groups.size(); ++g)
    for (std::size_t k = 0; k < groups[g].frames.size(); ++k) order.emplace_back(g, k);
  for (const CalibratedFrames& g : groups)
    if (g.stats) *g.stats = {};
  ExtractionStats total;
  Progress progress("extract + bin", static_cast<long>(order.size()), "img");
  std::size_t next = 0;
  struct Item {
    std::size_t index = 0;
    std::array<SampleBatch, 3> batches;  // [0] alone unless by site
    ExtractionStats stats;
  };
  tbb::task_arena arena(threads);
  arena.execute([&] {
    tbb::parallel_pipeline(
        in_flight,
        tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                            [&](tbb::flow_control& fc) -> std::size_t {
                                              if (next >= order.size()) {
                                                fc.stop();
                                                return 0;
                                              }
                                              return next++;
                                            }) &
            tbb::make_filter<std::size_t, std::shared_ptr<Item>>(
                tbb::filter_mode::parallel,
                [&](std::size_t k) {
                  auto item = std::make_shared<Item>();
                  item->index = k;
                  const auto [g, i] = order[k];
                  const SphereSampler& sampler = samplers[g];
                  const HdrFrame& f = groups[g].frames[i];
                  const ExrImage img = read_exr(f.path);
                  item->stats = by_site ? sampler.extract_sites(img, f.angle_deg, item->batches, f.path.string())
                                        : sampler.extract(img, f.angle_deg, item->batches[0], f.path.string());
                  return item;
                }) &
            tbb::make_filter<std::shared_ptr<Item>, void>(
                tbb::filter_mode::serial_in_order, [&](std::shared_ptr<Item> item) {
                  for (std::size_t a = 0; a < acc.size(); ++a) acc[a].add(item->batches[a]);
                  total.add(item->stats);
                  const auto [g, i] = order[item->index];
                  if (groups[g].stats) groups[g].stats->add(item->stats);
                  progress.step(groups.size() > 1
                                    ? fmt::format("session {} of {}, {:.1f} deg", g + 1, groups.size(),
                                                  groups[g].frames[i].angle_deg)
                                    : fmt::format("{:.1f} deg", groups[g].frames[i].angle_deg));
                }));
  });
  progress.finish(fmt::format("{} samples", total.samples));
  if (stats) *stats = total;
  std::vector<BinnedTable> out;
  for (const BinAccumulator& a : acc) out.push_back(a.finish());
  return out;
}

// One sampler per group (DataError for a group without frames or calibration), logged.
std::vector<SphereSampler> group_samplers(const std::vector<CalibratedFrames>& groups,
                                          const ExtractionOptions& extraction) {
  if (groups.empty()) throw DataError("no HDR images to extract samples from");
  std::vector<SphereSampler> samplers;
  for (const CalibratedFrames& g : groups) {
    if (g.frames.empty() || !g.calibration) throw DataError("no HDR images to extract samples from");
    samplers.emplace_back(*g.calibration, extraction);
    log_extraction(samplers.back(), extraction);
  }
  return samplers;
}

void log_extraction(const SphereSampler& sampler, const ExtractionOptions& extraction) {
  spdlog::info("extraction: {} sphere pixels per image (upper half, {:g} px inside the silhouette); lens blur {}{}",
               sampler.pixel_count(), extraction.margin_px,
               sampler.blur_sigma_px() > 0 ? fmt::format("of {:.3f} px corrected", sampler.blur_sigma_px())
                                           : std::string("not corrected"),
               extraction.cfa_sites ? "; each pixel's own filter colour only, binned by colour" : "");
}

}  // namespace

BinnedTable bin_frames(const std::vector<HdrFrame>& frames, const calib::RigCalibration& calibration,
                       const ExtractionOptions& extraction, const BinningOptions& binning, ExtractionStats* stats) {
  return bin_frames({CalibratedFrames{frames, &calibration, nullptr}}, extraction, binning, stats);
}

BinnedTable bin_frames(const std::vector<CalibratedFrames>& groups, const ExtractionOptions& extraction,
                       const BinningOptions& binning, ExtractionStats* stats) {
  extraction.check();
  if (extraction.cfa_sites)
    throw DataError("binning at the filter-array sites gives one table per colour (bin_frames_by_site)");
  const std::vector<SphereSampler> samplers = group_samplers(groups, extraction);
  return std::move(extract_and_bin(groups, samplers, extraction, binning, stats).front());
}

SiteTables bin_frames_by_site(const std::vector<HdrFrame>& frames, const calib::RigCalibration& calibration,
                              ExtractionOptions extraction, const BinningOptions& binning, ExtractionStats* stats) {
  return bin_frames_by_site({CalibratedFrames{frames, &calibration, nullptr}}, std::move(extraction), binning, stats);
}

SiteTables bin_frames_by_site(const std::vector<CalibratedFrames>& groups, ExtractionOptions extraction,
                              const BinningOptions& binning, ExtractionStats* stats) {
  extraction.cfa_sites = true;
  extraction.check();
  const std::vector<SphereSampler> samplers = group_samplers(groups, extraction);
  // The colour space of the frames decides the map back (extract_sites checks each image);
  // every group's sites must map to it alike.
  std::optional<Eigen::Matrix3d> to_colour_space;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const ExrImage first = read_exr(groups[g].frames.front().path);
    const auto space = first.attributes.find("paintlab.colour_space");
    const bool camera_rgb = space != first.attributes.end() && space->second == colour::kCameraRgb;
    const Eigen::Matrix3d m = camera_rgb || !samplers[g].site_to_srgb() ? Eigen::Matrix3d::Identity()
                                                                        : *samplers[g].site_to_srgb();
    if (to_colour_space && !to_colour_space->isApprox(m, 1e-9))
      throw DataError(fmt::format(
          "{}: its filter-array sites map to the colour space otherwise than {}'s (another colour calibration or "
          "colour space); sessions fitted together at their sites need the same colour calibration",
          groups[g].frames.front().path.parent_path().string(), groups[0].frames.front().path.parent_path().string()));
    to_colour_space = m;
  }
  SiteTables out;
  std::vector<BinnedTable> tables = extract_and_bin(groups, samplers, extraction, binning, stats);
  for (std::size_t c = 0; c < 3; ++c) out.tables[c] = std::move(tables[c]);
  out.to_colour_space = *to_colour_space;
  return out;
}

}  // namespace paintlab::fit
