#include "paintlab/acquisition/demosaic.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"

namespace paintlab::acq {

namespace {

constexpr EnumNames<DemosaicMethod, 2> kDemosaicNames{
    {{DemosaicMethod::Bilinear, "bilinear"}, {DemosaicMethod::EdgeAware, "edge-aware"}}};
constexpr EnumNames<MosaicInterpolation, 2> kInterpolationNames{
    {{MosaicInterpolation::Bilinear, "bilinear"}, {MosaicInterpolation::GradientCorrected, "gradient-corrected"}}};

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

const char* to_string(MosaicInterpolation m) { return enum_name(kInterpolationNames, m); }

MosaicInterpolation mosaic_interpolation_from_string(const std::string& s, const std::string& where) {
  return enum_from_name(kInterpolationNames, s, "demosaicing", where);
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

std::array<double, 3> ColourMap::apply(const std::array<double, 3>& camera) const {
  std::array<double, 3> b{camera[0] * balance[0], camera[1] * balance[1], camera[2] * balance[2]};
  if (nonlinear) return nonlinear(b);
  if (!matrix) return b;
  const auto& m = *matrix;
  return {m[0] * b[0] + m[1] * b[1] + m[2] * b[2], m[3] * b[0] + m[4] * b[1] + m[5] * b[2],
          m[6] * b[0] + m[7] * b[1] + m[8] * b[2]};
}

namespace {

// One demosaiced pixel: camera value, variance and validity per channel.
struct Demosaiced {
  float v[3];
  float var[3];
  bool ok[3];
};

// The bilinear estimate at (x, y) near the border (neighbours outside the image left out,
// the weights renormalised).
Demosaiced demosaic_at_border(const float* value, const float* variance, const float* valid, int w, int h, int x,
                              int y, const int colour[2][2]) {
  double sum[3] = {0, 0, 0}, sum_w[3] = {0, 0, 0}, sum_var[3] = {0, 0, 0};
  bool ok[3] = {true, true, true};
  const int own = colour[y & 1][x & 1];
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int sx = x + dx, sy = y + dy;
      if (sx < 0 || sy < 0 || sx >= w || sy >= h) continue;
      const int c = colour[sy & 1][sx & 1];
      if (c == own && (dx != 0 || dy != 0)) continue;  // a site keeps its own colour
      const std::size_t i = static_cast<std::size_t>(sy) * static_cast<std::size_t>(w) + static_cast<std::size_t>(sx);
      const double k = (2 - std::abs(dx)) * (2 - std::abs(dy));
      sum[c] += k * value[i];
      sum_w[c] += k;
      sum_var[c] += k * k * variance[i];
      ok[c] = ok[c] && valid[i] > 0.5f;
    }
  Demosaiced d{};
  for (int c = 0; c < 3; ++c) {
    d.v[c] = static_cast<float>(sum[c] / sum_w[c]);
    d.var[c] = static_cast<float>(sum_var[c] / (sum_w[c] * sum_w[c]));
    d.ok[c] = ok[c];
  }
  return d;
}

// One pixel through the colour map with its variance: the map's Jacobian by forward
// differences (exact for a matrix) carries each channel's variance into the outputs it enters;
// an invalid channel gives those outputs an infinite variance.
struct Mapped {
  std::array<float, 3> value;
  std::array<float, 3> var;
};
Mapped map_pixel(const ColourMap& map, const std::array<double, 3>& cam, const std::array<double, 3>& var,
                 const bool ok[3]) {
  const std::array<double, 3> f = map.apply(cam);
  double var_out[3] = {0, 0, 0};
  bool bad[3] = {false, false, false};
  const double step = 1e-4 * std::max({std::abs(cam[0]), std::abs(cam[1]), std::abs(cam[2]), 1e-12});
  for (int j = 0; j < 3; ++j) {
    std::array<double, 3> shifted = cam;
    shifted[static_cast<std::size_t>(j)] += step;
    const std::array<double, 3> g = map.apply(shifted);
    for (int r = 0; r < 3; ++r) {
      const double d = (g[static_cast<std::size_t>(r)] - f[static_cast<std::size_t>(r)]) / step;
      if (d == 0.0) continue;
      if (!ok[j]) bad[r] = true;
      var_out[r] += d * d * var[static_cast<std::size_t>(j)];
    }
  }
  Mapped m{};
  for (int r = 0; r < 3; ++r) {
    m.value[static_cast<std::size_t>(r)] = static_cast<float>(f[static_cast<std::size_t>(r)]);
    m.var[static_cast<std::size_t>(r)] = bad[r] || !std::isfinite(var_out[r])
                                             ? std::numeric_limits<float>::infinity()
                                             : static_cast<float>(var_out[r]);
  }
  return m;
}

// The interior's four kinds of site: the colour a site sees and, for a green site, the colour
// of its left and right neighbours.
enum SiteKind { kRedSite = 0, kBlueSite = 1, kGreenAcrossRed = 2, kGreenAcrossBlue = 3 };

// What the fast path reads and writes: the mosaic's planes, the output planes and the linear
// colour map (balance folded in) with its squares for the variance.
struct Kernel {
  const float* value;
  const float* variance;
  const float* valid;
  float* out[3];
  float* out_var[3];
  float* out_ok;
  std::size_t W;
  int w;
  float m[9], m2[9];
  bool mixes[9];  // m[r][c] != 0: an invalid channel c spoils output r
};

// The bilinear estimate at an interior site of kind K (constant indices: the compiler keeps
// the three channels in registers), mapped and stored.
template <int K>
inline void interior_pixel(const Kernel& k, std::size_t i) {
  const float* v = k.value;
  const float* q = k.variance;
  const float* a = k.valid;
  const std::size_t up = i - k.W, down = i + k.W;
  float c[3], var[3];
  bool ok[3];
  auto site = [&](int ch) {
    c[ch] = v[i];
    var[ch] = q[i];
    ok[ch] = a[i] > 0.5f;
  };
  auto four = [&](int ch, std::size_t s0, std::size_t s1, std::size_t s2, std::size_t s3) {
    c[ch] = 0.25f * (v[s0] + v[s1] + v[s2] + v[s3]);
    var[ch] = 0.0625f * (q[s0] + q[s1] + q[s2] + q[s3]);
    ok[ch] = (a[s0] > 0.5f) & (a[s1] > 0.5f) & (a[s2] > 0.5f) & (a[s3] > 0.5f);
  };
  auto two = [&](int ch, std::size_t s0, std::size_t s1) {
    c[ch] = 0.5f * (v[s0] + v[s1]);
    var[ch] = 0.25f * (q[s0] + q[s1]);
    ok[ch] = (a[s0] > 0.5f) & (a[s1] > 0.5f);
  };
  if constexpr (K == kRedSite || K == kBlueSite) {
    constexpr int own = K == kRedSite ? 0 : 2;
    site(own);
    four(1, i - 1, i + 1, up, down);
    four(2 - own, up - 1, up + 1, down - 1, down + 1);
  } else {
    constexpr int across = K == kGreenAcrossRed ? 0 : 2;
    site(1);
    two(across, i - 1, i + 1);
    two(2 - across, up, down);
  }
  k.out_ok[i] = (ok[0] && ok[1] && ok[2]) ? 1.0f : 0.0f;
  constexpr float inf = std::numeric_limits<float>::infinity();
  for (int r = 0; r < 3; ++r) {
    k.out[r][i] = k.m[3 * r] * c[0] + k.m[3 * r + 1] * c[1] + k.m[3 * r + 2] * c[2];
    const bool bad = (!ok[0] & k.mixes[3 * r]) | (!ok[1] & k.mixes[3 * r + 1]) | (!ok[2] & k.mixes[3 * r + 2]);
    const float sum = k.m2[3 * r] * var[0] + k.m2[3 * r + 1] * var[1] + k.m2[3 * r + 2] * var[2];
    k.out_var[r][i] = bad ? inf : sum;
  }
}

// The interior of row y: odd columns of kind KOdd, even ones of kind KEven.
template <int KEven, int KOdd>
void interior_row(const Kernel& k, int y) {
  const std::size_t row = static_cast<std::size_t>(y) * k.W;
  int x = 1;
  for (; x + 1 < k.w - 1; x += 2) {
    interior_pixel<KOdd>(k, row + static_cast<std::size_t>(x));
    interior_pixel<KEven>(k, row + static_cast<std::size_t>(x) + 1);
  }
  if (x < k.w - 1) interior_pixel<KOdd>(k, row + static_cast<std::size_t>(x));
}

using RowFn = void (*)(const Kernel&, int);
template <int A>
constexpr std::array<RowFn, 4> kRowsOf = {interior_row<A, 0>, interior_row<A, 1>, interior_row<A, 2>,
                                          interior_row<A, 3>};
constexpr std::array<std::array<RowFn, 4>, 4> kRows = {kRowsOf<0>, kRowsOf<1>, kRowsOf<2>, kRowsOf<3>};


// ---- gradient-corrected (Malvar, He and Cutler 2004) ----

// One tap of a 5x5 kernel: offset and weight (the paper's weights, already divided by 8).
struct Tap {
  int dx, dy;
  float w;
};
struct Taps {
  Tap t[13];
  int n = 0;
};

// The paper's four kernels, for a missing colour at a site: green at a red or blue site; red
// at a blue site (or blue at a red one: the diagonal neighbours); the colour of a green site's
// left and right neighbours; the colour of its upper and lower neighbours.
constexpr int kGreenAtRb = 0, kDiagonal = 1, kAcrossRow = 2, kAcrossColumn = 3;
Taps mhc_kernel(int which) {
  Taps k;
  auto add = [&k](int dx, int dy, double w8) { k.t[k.n++] = {dx, dy, static_cast<float>(w8 / 8.0)}; };
  switch (which) {
    case kGreenAtRb:
      add(0, 0, 4);
      for (int s : {-1, 1}) add(s, 0, 2), add(0, s, 2), add(2 * s, 0, -1), add(0, 2 * s, -1);
      break;
    case kDiagonal:
      add(0, 0, 6);
      for (int s : {-1, 1}) add(s, -1, 2), add(s, 1, 2), add(2 * s, 0, -1.5), add(0, 2 * s, -1.5);
      break;
    case kAcrossRow:
      add(0, 0, 5);
      for (int s : {-1, 1}) add(s, 0, 4), add(2 * s, 0, -1), add(s, -1, -1), add(s, 1, -1), add(0, 2 * s, 0.5);
      break;
    default:  // kAcrossColumn: the transpose
      add(0, 0, 5);
      for (int s : {-1, 1}) add(0, s, 4), add(0, 2 * s, -1), add(-1, s, -1), add(1, s, -1), add(2 * s, 0, 0.5);
      break;
  }
  return k;
}

// For each kind of site (SiteKind) and output colour c: the kernel, or -1 for the site's own
// colour (its value as it is).
constexpr int kOwn = -1;
constexpr int kMhcKernelOf[4][3] = {
    {kOwn, kGreenAtRb, kDiagonal},          // red site
    {kDiagonal, kGreenAtRb, kOwn},          // blue site
    {kAcrossRow, kOwn, kAcrossColumn},      // green between reds
    {kAcrossColumn, kOwn, kAcrossRow},      // green between blues
};

// What the gradient-corrected path needs: the mosaic, the balance per colour, the matrix
// (balance not folded in) and the colour of each site.
struct MhcInput {
  const float* value;
  const float* variance;
  const float* valid;
  std::size_t W;
  int colour[2][2];
  float balance[3];
  float m[9];
  std::array<Taps, 4> kernels;
};

// Camera RGB (balanced) at interior pixel (x, y) (2 <= x < w - 2, likewise y) with, per
// output r of the matrix, the coefficient of each of the 5x5 sites (row-major, centre 12) in
// it, for the variance.
struct MhcPixel {
  float v[3];
  bool ok[3];
  float coef[3][25];  // per camera channel c: weight of site s in balanced value c
};
void mhc_pixel(const MhcInput& in, int x, int y, int kind, MhcPixel* p) {
  const std::size_t centre = static_cast<std::size_t>(y) * in.W + static_cast<std::size_t>(x);
  for (int c = 0; c < 3; ++c) {
    std::fill(std::begin(p->coef[c]), std::end(p->coef[c]), 0.0f);
    const int which = kMhcKernelOf[kind][c];
    if (which == kOwn) {
      const float b = in.balance[c];
      p->v[c] = b * in.value[centre];
      p->ok[c] = in.valid[centre] > 0.5f;
      p->coef[c][12] = b;
      continue;
    }
    const Taps& k = in.kernels[static_cast<std::size_t>(which)];
    float sum = 0.0f;
    bool ok = true;
    for (int t = 0; t < k.n; ++t) {
      const int sx = x + k.t[t].dx, sy = y + k.t[t].dy;
      const std::size_t i = static_cast<std::size_t>(sy) * in.W + static_cast<std::size_t>(sx);
      const float wb = k.t[t].w * in.balance[in.colour[sy & 1][sx & 1]];
      sum += wb * in.value[i];
      ok = ok && in.valid[i] > 0.5f;
      p->coef[c][(k.t[t].dy + 2) * 5 + (k.t[t].dx + 2)] = wb;
    }
    p->v[c] = sum;
    p->ok[c] = ok;
  }
}

}  // namespace

ExrImage demosaic_to_colour(const ExrImage& mosaic, const ColourMap& map) {
  if (map.pattern == dev::CfaPattern::None)
    throw DataError("demosaic: the merged image has no colour filter array (pattern none)");
  const ImageF* value_plane = mosaic.find("Y");
  const ImageF* variance_plane = mosaic.find("var.Y");
  const ImageF* valid_plane = mosaic.find("valid");
  if (!value_plane || !variance_plane || !valid_plane)
    throw DataError("demosaic: a merged mosaic has the planes Y, var.Y and valid (the HDR merge of a Bayer bracket)");
  const int w = mosaic.width, h = mosaic.height;
  if (w < 2 || h < 2) throw DataError(fmt::format("demosaic: a {}x{} mosaic holds no 2x2 filter block", w, h));
  int colour[2][2];
  for (int py = 0; py < 2; ++py)
    for (int px = 0; px < 2; ++px) colour[py][px] = dev::cfa_colour(map.pattern, px, py);
  const float* value = value_plane->data();
  const float* variance = variance_plane->data();
  const float* valid = valid_plane->data();

  ExrImage out;
  out.width = w;
  out.height = h;
  out.attributes = mosaic.attributes;
  out.attributes["paintlab.colour_space"] = map.colour_space;
  out.attributes["paintlab.cfa"] = dev::to_string(map.pattern);
  out.attributes["paintlab.demosaic"] = to_string(map.interpolation);
  std::vector<ImageF> planes(7);
  tbb::parallel_for(0, 7, [&](int k) { planes[static_cast<std::size_t>(k)] = ImageF(w, h, 1); });
  float* o_v[3] = {planes[0].data(), planes[1].data(), planes[2].data()};
  float* o_var[3] = {planes[3].data(), planes[4].data(), planes[5].data()};
  float* o_ok = planes[6].data();

  // The colour map's coefficients on the balanced values, and their squares for the variance.
  const bool linear = !map.nonlinear;
  float m[9], m2[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double mij = map.matrix ? (*map.matrix)[static_cast<std::size_t>(3 * i + j)] : (i == j ? 1.0 : 0.0);
      const double b = map.balance[static_cast<std::size_t>(j)];
      m[3 * i + j] = static_cast<float>(mij * b);
      m2[3 * i + j] = static_cast<float>(mij * b * mij * b);
    }
  const float inf = std::numeric_limits<float>::infinity();

  auto store = [&](std::size_t i, const Demosaiced& d) {
    const bool ok = d.ok[0] && d.ok[1] && d.ok[2];
    o_ok[i] = ok ? 1.0f : 0.0f;
    if (linear) {
      for (int r = 0; r < 3; ++r) {
        o_v[r][i] = m[3 * r] * d.v[0] + m[3 * r + 1] * d.v[1] + m[3 * r + 2] * d.v[2];
        // An invalid channel spoils the outputs it enters (camera RGB keeps the others).
        const bool bad = (!d.ok[0] && m2[3 * r] != 0.0f) || (!d.ok[1] && m2[3 * r + 1] != 0.0f) ||
                         (!d.ok[2] && m2[3 * r + 2] != 0.0f);
        o_var[r][i] = bad ? inf : m2[3 * r] * d.var[0] + m2[3 * r + 1] * d.var[1] + m2[3 * r + 2] * d.var[2];
      }
      return;
    }
    const Mapped p = map_pixel(map, {d.v[0], d.v[1], d.v[2]}, {d.var[0], d.var[1], d.var[2]}, d.ok);
    for (int r = 0; r < 3; ++r) {
      o_v[r][i] = p.value[static_cast<std::size_t>(r)];
      o_var[r][i] = p.var[static_cast<std::size_t>(r)];
    }
  };

  const std::size_t W = static_cast<std::size_t>(w);
  Kernel kernel{value, variance, valid, {o_v[0], o_v[1], o_v[2]}, {o_var[0], o_var[1], o_var[2]}, o_ok, W, w, {}, {}, {}};
  for (int j = 0; j < 9; ++j) {
    kernel.m[j] = m[j];
    kernel.m2[j] = m2[j];
    kernel.mixes[j] = m2[j] != 0.0f;
  }
  // The kind of site at (x, y) of the interior.
  auto kind = [&](int x, int y) {
    const int own = colour[y & 1][x & 1];
    if (own == 0) return kRedSite;
    if (own == 2) return kBlueSite;
    return colour[y & 1][(x + 1) & 1] == 0 ? kGreenAcrossRed : kGreenAcrossBlue;
  };
  const RowFn rows_of[2] = {kRows[static_cast<std::size_t>(kind(0, 0))][static_cast<std::size_t>(kind(1, 0))],
                            kRows[static_cast<std::size_t>(kind(0, 1))][static_cast<std::size_t>(kind(1, 1))]};
  const bool mhc = map.interpolation == MosaicInterpolation::GradientCorrected;
  MhcInput mi{value, variance, valid, W, {}, {}, {}, {}};
  if (mhc) {
    for (int py = 0; py < 2; ++py)
      for (int px = 0; px < 2; ++px) mi.colour[py][px] = colour[py][px];
    for (int c = 0; c < 3; ++c) mi.balance[c] = static_cast<float>(map.balance[static_cast<std::size_t>(c)]);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        mi.m[3 * i + j] = map.matrix ? static_cast<float>((*map.matrix)[static_cast<std::size_t>(3 * i + j)])
                                     : (i == j ? 1.0f : 0.0f);
    for (int k = 0; k < 4; ++k) mi.kernels[static_cast<std::size_t>(k)] = mhc_kernel(k);
  }
  // One interior pixel, gradient-corrected: the matrix's outputs with their exact variance
  // (each site's coefficient in an output summed over the channels it enters).
  auto store_mhc = [&](int x, int y) {
    MhcPixel p;
    mhc_pixel(mi, x, y, kind(x, y), &p);
    const std::size_t i = static_cast<std::size_t>(y) * W + static_cast<std::size_t>(x);
    auto site_var = [&](int s) {
      return variance[static_cast<std::size_t>(y + s / 5 - 2) * W + static_cast<std::size_t>(x + s % 5 - 2)];
    };
    o_ok[i] = (p.ok[0] && p.ok[1] && p.ok[2]) ? 1.0f : 0.0f;
    if (linear) {
      for (int r = 0; r < 3; ++r) {
        const float* mr = mi.m + 3 * r;
        o_v[r][i] = mr[0] * p.v[0] + mr[1] * p.v[1] + mr[2] * p.v[2];
        const bool bad = (!p.ok[0] && mr[0] != 0.0f) || (!p.ok[1] && mr[1] != 0.0f) || (!p.ok[2] && mr[2] != 0.0f);
        double var_r = 0.0;
        if (!bad)
          for (int s = 0; s < 25; ++s) {
            const double a = mr[0] * p.coef[0][s] + mr[1] * p.coef[1][s] + mr[2] * p.coef[2][s];
            if (a != 0.0) var_r += a * a * site_var(s);
          }
        o_var[r][i] = bad ? inf : static_cast<float>(var_r);
      }
      return;
    }
    std::array<double, 3> cam{}, var{};
    for (int c = 0; c < 3; ++c) {
      const double b = mi.balance[c];
      double q = 0.0;
      for (int s = 0; s < 25; ++s)
        if (p.coef[c][s] != 0.0f) q += static_cast<double>(p.coef[c][s]) * p.coef[c][s] * site_var(s);
      cam[static_cast<std::size_t>(c)] = p.v[c] / b;
      var[static_cast<std::size_t>(c)] = q / (b * b);
    }
    const Mapped mp = map_pixel(map, cam, var, p.ok);
    for (int r = 0; r < 3; ++r) {
      o_v[r][i] = mp.value[static_cast<std::size_t>(r)];
      o_var[r][i] = mp.var[static_cast<std::size_t>(r)];
    }
  };
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 16), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      const std::size_t row = static_cast<std::size_t>(y) * W;
      if (mhc && y >= 2 && y < h - 2 && w >= 5) {
        for (int x = 0; x < w; ++x) {
          if (x >= 2 && x < w - 2)
            store_mhc(x, y);
          else
            store(row + static_cast<std::size_t>(x), demosaic_at_border(value, variance, valid, w, h, x, y, colour));
        }
        continue;
      }
      if (mhc || y == 0 || y == h - 1) {
        for (int x = 0; x < w; ++x)
          store(row + static_cast<std::size_t>(x), demosaic_at_border(value, variance, valid, w, h, x, y, colour));
        continue;
      }
      store(row, demosaic_at_border(value, variance, valid, w, h, 0, y, colour));
      store(row + W - 1, demosaic_at_border(value, variance, valid, w, h, w - 1, y, colour));
      if (linear) {
        rows_of[y & 1](kernel, y);
        continue;
      }
      for (int x = 1; x < w - 1; ++x) {  // the non-linear map: the general path
        const std::size_t i = row + static_cast<std::size_t>(x);
        store(i, demosaic_at_border(value, variance, valid, w, h, x, y, colour));
      }
    }
  });
  const char* names[7] = {"R", "G", "B", "var.R", "var.G", "var.B", "valid"};
  for (int k = 0; k < 7; ++k) out.add(names[k], std::move(planes[static_cast<std::size_t>(k)]));
  return out;
}

ExrImage map_colour(const std::array<const ExrImage*, 3>& channels, const ColourMap& map) {
  const ImageF* v[3];
  const ImageF* q[3];
  const ImageF* a[3];
  for (int c = 0; c < 3; ++c) {
    const ExrImage& e = *channels[static_cast<std::size_t>(c)];
    v[c] = e.find("Y");
    q[c] = e.find("var.Y");
    a[c] = e.find("valid");
    if (!v[c] || !q[c] || !a[c])
      throw DataError("map_colour: each channel's merged image has the planes Y, var.Y and valid");
    if (e.width != channels[0]->width || e.height != channels[0]->height)
      throw DataError(fmt::format("map_colour: the channels' images differ in size ({}x{} and {}x{})", e.width,
                                  e.height, channels[0]->width, channels[0]->height));
  }
  const int w = channels[0]->width, h = channels[0]->height;
  ExrImage out;
  out.width = w;
  out.height = h;
  out.attributes = channels[0]->attributes;
  out.attributes["paintlab.colour_space"] = map.colour_space;
  std::vector<ImageF> planes(7);
  tbb::parallel_for(0, 7, [&](int k) { planes[static_cast<std::size_t>(k)] = ImageF(w, h, 1); });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, static_cast<std::size_t>(w) * static_cast<std::size_t>(h), 4096),
                    [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      std::array<double, 3> cam{};
      std::array<double, 3> var{};
      bool ok[3];
      for (int c = 0; c < 3; ++c) {
        cam[static_cast<std::size_t>(c)] = v[c]->data()[i];
        var[static_cast<std::size_t>(c)] = q[c]->data()[i];
        ok[c] = a[c]->data()[i] > 0.5f;
      }
      const Mapped p = map_pixel(map, cam, var, ok);
      for (int r = 0; r < 3; ++r) {
        planes[static_cast<std::size_t>(r)].data()[i] = p.value[static_cast<std::size_t>(r)];
        planes[static_cast<std::size_t>(3 + r)].data()[i] = p.var[static_cast<std::size_t>(r)];
      }
      planes[6].data()[i] = ok[0] && ok[1] && ok[2] ? 1.0f : 0.0f;
    }
  });
  const char* names[7] = {"R", "G", "B", "var.R", "var.G", "var.B", "valid"};
  for (int k = 0; k < 7; ++k) out.add(names[k], std::move(planes[static_cast<std::size_t>(k)]));
  return out;
}

ExrImage demosaic_merged(const ExrImage& mosaic, dev::CfaPattern pattern) {
  ColourMap map;
  map.pattern = pattern;
  ExrImage out = demosaic_to_colour(mosaic, map);
  out.attributes = mosaic.attributes;  // camera RGB: nothing to state beyond what the mosaic said
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
