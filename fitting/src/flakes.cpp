#include "paintlab/fitting/flakes.h"

#include <lemon/network_simplex.h>
#include <lemon/smart_graph.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fmt/format.h>
#include <functional>
#include <memory>
#include <numeric>
#include <random>

#include "paintlab/core/error.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/log.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/progress.h"
#include "paintlab/fitting/export.h"
#include "paintlab/fitting/pipeline.h"
#include "paintlab/fitting/session_binning.h"

namespace paintlab::fit {

namespace {

constexpr const char* kFlakesFormat = "paintlab-flakes";
constexpr int kFlakesFormatVersion = 1;
constexpr std::array<double, 3> kInstrumentAngles = {15.0, 45.0, 75.0};
constexpr std::array<double, 5> kQuantiles = {0.10, 0.25, 0.50, 0.75, 0.90};

// A direction in air (z > 0) refracted into a coat of index `ior`, still pointing away from
// the surface: the tangential part divided by the index.
Vec3 refract_up(const Vec3& w, double ior) {
  const double x = w.x() / ior, y = w.y() / ior;
  return Vec3(x, y, std::sqrt(std::max(0.0, 1.0 - x * x - y * y)));
}

int bin_of(double theta, int num) {
  const int b = static_cast<int>(std::floor(num * theta / (0.5 * kPi)));
  return std::clamp(b, 0, num - 1);
}

double angle_between_units(const Vec3& a, const Vec3& b) {
  // atan2 of the cross and dot products: accurate for small angles too.
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// One glint of a slice: its contrast and colour.
struct Glint {
  float contrast;
  float model_y;  // Y of the smooth model there (1/sr)
  colour::Lab lab;
};

// What a thread gathers for one slice.
struct SliceAcc {
  std::uint64_t pixels = 0;
  std::vector<Glint> glints;
  std::uint64_t runs = 0;
  double chord_sum_rad = 0.0;
};

struct InstrumentAcc {
  std::uint64_t pixels = 0, glints = 0;
  double contrast_sum = 0.0;
};

// Everything summed over the sweep.
struct SweepAcc {
  std::vector<SliceAcc> slices;
  std::array<InstrumentAcc, 3> instrument{};
  double step_sum = 0.0;
  std::uint64_t steps = 0;
  explicit SweepAcc(std::size_t n) : slices(n) {}
};

// A pixel across the sweep: its run of glinting positions so far.
struct PixelTrack {
  std::int32_t last_seen = -2;   // frame index
  std::int32_t last_glint = -2;
  std::int32_t run_len = 0;
  std::int16_t run_slice = -1;
  float last_step = 0.0f;        // rad, half vector between the last two positions seen
  Eigen::Vector3f h{0.0f, 0.0f, 0.0f};
};

}  // namespace

void FlakeOptions::check() const {
  auto fail = [](const char* key, double v, const char* rule) {
    throw OptionError(std::string("FlakeOptions::") + key, fmt::format("{}", v), rule);
  };
  if (!(ior >= 1.0 && ior <= 3.0)) fail("ior", ior, "in [1, 3]");
  if (num_theta_f < 1 || num_theta_f > 64) fail("num_theta_f", num_theta_f, "in [1, 64]");
  if (num_theta_i < 1 || num_theta_i > 64) fail("num_theta_i", num_theta_i, "in [1, 64]");
  if (num_theta_f * num_theta_i >= 256)
    fail("num_theta_f x num_theta_i", num_theta_f * num_theta_i, "below 256 (the slice LUT is 8-bit)");
  if (!(threshold_sigma > 0.0)) fail("threshold_sigma", threshold_sigma, "> 0");
  if (!(threshold_ratio > 0.0)) fail("threshold_ratio", threshold_ratio, "> 0");
  if (!(model_error >= 0.0)) fail("model_error", model_error, ">= 0");
  if (clusters < 1 || clusters > 255) fail("clusters", clusters, "in [1, 255]");
  if (cdf_steps < 2 || cdf_steps > 100000) fail("cdf_steps", cdf_steps, "in [2, 100000]");
  if (min_glints < 1) fail("min_glints", min_glints, ">= 1");
  if (!(instrument_tolerance_deg > 0.0 && instrument_tolerance_deg <= 30.0))
    fail("instrument_tolerance_deg", instrument_tolerance_deg, "in (0, 30]");
  if (threads < 0) fail("threads", threads, ">= 0");
}

const FlakeSlice* FlakeStats::slice(int theta_f, int theta_i) const {
  for (const FlakeSlice& s : slices)
    if (s.theta_f == theta_f && s.theta_i == theta_i) return &s;
  return nullptr;
}

std::array<int, 2> flake_slice_of(const Vec3& wi, const Vec3& wo, double ior, int num_theta_f, int num_theta_i) {
  const Vec3 i = refract_up(wi.normalized(), ior), o = refract_up(wo.normalized(), ior);
  const Vec3 h = (i + o).normalized();
  const double theta_f = std::acos(std::clamp(h.z(), -1.0, 1.0));
  const double theta_i = angle_between_units(h, i);
  return {bin_of(theta_f, num_theta_f), bin_of(theta_i, num_theta_i)};
}

void cluster_flake_colours(const std::vector<colour::Lab>& colours, int clusters, int cdf_steps,
                           std::vector<FlakeCluster>* out, std::vector<std::uint8_t>* inverse_cdf) {
  out->clear();
  inverse_cdf->clear();
  if (colours.empty()) return;
  // The octree over the colours' box, 6 levels (64 cells a side).
  constexpr int kDepth = 6;
  constexpr int kSide = 1 << kDepth;
  // The box spans the 1st to 99th percentile of each axis; the colours outside go to its edge
  // cells. A box over all colours gives its 64 cells to a few outliers (the noisy contrast of a
  // faint glint) and leaves the bulk of the colours a handful of cells: on the simulator the
  // colour distribution of one sweep then differed from the next sweep's by up to 3.6 dE (EMD),
  // with the percentile box by at most 1.0 dE.
  std::vector<Eigen::Vector3d> keys;
  keys.reserve(colours.size());
  for (const colour::Lab& c : colours) keys.emplace_back(c.L, c.a, c.b);
  Eigen::Vector3d lo, hi;
  {
    const std::size_t n = keys.size(), cut = n / 100;
    std::vector<double> v(n);
    for (int ax = 0; ax < 3; ++ax) {
      for (std::size_t i = 0; i < n; ++i) v[i] = keys[i][ax];
      std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(cut), v.end());
      lo[ax] = v[cut];
      std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n - 1 - cut), v.end());
      hi[ax] = v[n - 1 - cut];
    }
  }
  const Eigen::Vector3d extent = (hi - lo).cwiseMax(1e-9);
  struct Node {
    std::array<std::int32_t, 8> child;
    int level;
    std::uint64_t count = 0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
    bool leaf() const {
      return std::all_of(child.begin(), child.end(), [](std::int32_t c) { return c < 0; });
    }
  };
  std::vector<Node> nodes;
  auto make = [&](int level) {
    Node n;
    n.child.fill(-1);
    n.level = level;
    nodes.push_back(n);
    return static_cast<std::int32_t>(nodes.size() - 1);
  };
  make(0);
  for (std::size_t ci = 0; ci < colours.size(); ++ci) {
    const colour::Lab& c = colours[ci];
    const Eigen::Vector3d v(c.L, c.a, c.b);
    std::array<int, 3> q{};
    for (int k = 0; k < 3; ++k)
      q[static_cast<std::size_t>(k)] =
          std::clamp(static_cast<int>(std::floor((keys[ci][k] - lo[k]) / extent[k] * kSide)), 0, kSide - 1);
    std::int32_t at = 0;
    for (int level = 0;; ++level) {
      Node& n = nodes[static_cast<std::size_t>(at)];
      n.count += 1;
      n.sum += v;
      n.sum2 += v.cwiseProduct(v);
      if (level == kDepth) break;
      const int shift = kDepth - 1 - level;
      const int idx = (((q[0] >> shift) & 1) << 2) | (((q[1] >> shift) & 1) << 1) | ((q[2] >> shift) & 1);
      std::int32_t next = n.child[static_cast<std::size_t>(idx)];
      if (next < 0) {
        next = make(level + 1);  // may move `nodes`: n is not used after this
        nodes[static_cast<std::size_t>(at)].child[static_cast<std::size_t>(idx)] = next;
      }
      at = next;
    }
  }
  // Reduction: merge the children of the deepest nodes, smallest first, until at most
  // `clusters` leaves are left (a node whose children are merged becomes a leaf).
  std::size_t leaves = 0;
  for (const Node& n : nodes) leaves += n.leaf() ? 1 : 0;
  for (int level = kDepth - 1; level >= 0 && leaves > static_cast<std::size_t>(clusters); --level) {
    std::vector<std::int32_t> at_level;
    for (std::size_t i = 0; i < nodes.size(); ++i)
      if (nodes[i].level == level && !nodes[i].leaf()) at_level.push_back(static_cast<std::int32_t>(i));
    std::stable_sort(at_level.begin(), at_level.end(), [&](std::int32_t a, std::int32_t b) {
      return nodes[static_cast<std::size_t>(a)].count < nodes[static_cast<std::size_t>(b)].count;
    });
    for (std::int32_t i : at_level) {
      if (leaves <= static_cast<std::size_t>(clusters)) break;
      Node& n = nodes[static_cast<std::size_t>(i)];
      std::size_t kids = 0;
      for (std::int32_t& c : n.child)
        if (c >= 0) {
          ++kids;
          c = -1;
        }
      leaves -= kids - 1;
    }
  }
  // The leaves reachable from the root.
  std::vector<std::int32_t> stack = {0};
  const double total = static_cast<double>(colours.size());
  while (!stack.empty()) {
    const Node& n = nodes[static_cast<std::size_t>(stack.back())];
    stack.pop_back();
    if (n.leaf()) {
      FlakeCluster c;
      c.count = n.count;
      c.probability = static_cast<double>(n.count) / total;
      const Eigen::Vector3d m = n.sum / static_cast<double>(n.count);
      // The cuboid whose uniform draws have the cluster's mean and variance per axis: mean
      // +- sqrt(3) sd (the bounding box of a merged leaf is far wider than its colours).
      const Eigen::Vector3d var = (n.sum2 / static_cast<double>(n.count) - m.cwiseProduct(m)).cwiseMax(0.0);
      const Eigen::Vector3d half = (3.0 * var).cwiseSqrt();
      c.mean = {m[0], m[1], m[2]};
      c.lo = {m[0] - half[0], m[1] - half[1], m[2] - half[2]};
      c.hi = {m[0] + half[0], m[1] + half[1], m[2] + half[2]};
      out->push_back(c);
      continue;
    }
    for (std::int32_t c : n.child)
      if (c >= 0) stack.push_back(c);
  }
  std::stable_sort(out->begin(), out->end(),
                   [](const FlakeCluster& a, const FlakeCluster& b) { return a.probability > b.probability; });
  // Inverse CDF: entry k is the cluster where the cumulative probability passes (k + 0.5) / steps.
  *inverse_cdf = flake_inverse_cdf(*out, cdf_steps);
}

namespace {

// extract_flakes over `count` images: image(k) gives the k-th (in sweep order), angle(k) its
// table angle, name(k) what errors call it.
FlakeStats extract_flakes_from(std::size_t count, const std::function<std::shared_ptr<const ExrImage>(std::size_t)>& image,
                               const std::function<double(std::size_t)>& angle,
                               const std::function<std::string(std::size_t)>& name,
                               const calib::RigCalibration& calibration, const brdf::Brdf& model,
                               const FlakeOptions& options, const ExtractionOptions& extraction) {
  options.check();
  if (count == 0) throw DataError("flake extraction: no HDR images");
  ExtractionOptions ex = extraction;
  ex.cfa_sites = false;
  ex.blur_sigma_px = 0.0;
  const SphereSampler sampler(calibration, ex);
  const int nf = options.num_theta_f, ni = options.num_theta_i;
  const std::size_t n_slices = static_cast<std::size_t>(nf) * static_cast<std::size_t>(ni);
  auto slice_index = [&](const std::array<int, 2>& s) { return static_cast<std::size_t>(s[1]) * nf + s[0]; };

  FlakeStats out;
  out.options = options;
  const double tol = deg_to_rad(options.instrument_tolerance_deg);
  // One image's observations, in pixel order (stage 1 of the pipeline below).
  struct Obs {
    std::uint32_t pixel;
    std::uint16_t slice;
    std::uint8_t glint;       // 0 or 1
    std::uint8_t instrument;  // bit g: within the tolerance of instrument geometry g
    float contrast;
    float model_y;
    Eigen::Vector3f h;
    float lab[3];             // glints only
  };
  struct Item {
    std::size_t index = 0;
    bool mono = false;
    std::string colour_space;
    std::vector<Obs> obs;
  };
  auto observe = [&](std::size_t k) {
    auto item = std::make_shared<Item>();
    item->index = k;
    const std::shared_ptr<const ExrImage> image_k = image(k);
    const ExrImage& hdr = *image_k;
    item->mono = hdr.find("Y") != nullptr;
    const auto it = hdr.attributes.find("paintlab.colour_space");
    item->colour_space = it == hdr.attributes.end() || it->second.empty() ? colour::kCameraRgb : it->second;
    // Luminance: Y of linear sRGB; a monochrome image's one channel.
    const Eigen::Vector3d lum = item->mono ? Eigen::Vector3d(1.0, 0.0, 0.0) : Eigen::Vector3d(0.2126, 0.7152, 0.0722);
    std::vector<Obs> all(sampler.pixel_count());
    std::vector<std::uint8_t> present(sampler.pixel_count(), 0);
    sampler.for_each_value(hdr, angle(k), [&](const SphereSampler::PixelValue& v) {
      const brdf::Rgb m = model.eval(v.wi, v.wo);
      const Eigen::Vector3d meas(v.rgb[0], v.rgb[1], v.rgb[2]);
      const Eigen::Vector3d var(v.var[0], v.var[1], v.var[2]);
      const Eigen::Vector3d mod(m[0], m[1], m[2]);
      const double l_model = lum.dot(mod), l_excess = lum.dot(meas - mod);
      const double sigma = std::sqrt(lum.cwiseProduct(lum).dot(var) + std::pow(options.model_error * l_model, 2));
      Obs o{};
      o.pixel = v.pixel;
      o.slice = static_cast<std::uint16_t>(slice_index(flake_slice_of(v.wi, v.wo, options.ior, nf, ni)));
      o.glint = l_model > 0.0 && l_excess > options.threshold_sigma * sigma &&
                l_excess > options.threshold_ratio * l_model;
      o.contrast = l_model > 0.0 ? static_cast<float>(l_excess / l_model) : 0.0f;
      o.model_y = static_cast<float>(l_model);
      o.h = v.h_cam.cast<float>();
      if (o.glint) {
        // The glint's contrast colour: its excess over the model's luminance there (Y = the
        // contrast; L* 100 at a contrast of 1).
        const Eigen::Vector3d excess = (meas - mod).cwiseMax(0.0) / l_model;
        const colour::Lab lab = colour::srgb_to_lab(item->mono ? colour::Rgb::Constant(excess[0]) : colour::Rgb(excess));
        o.lab[0] = static_cast<float>(lab.L);
        o.lab[1] = static_cast<float>(lab.a);
        o.lab[2] = static_cast<float>(lab.b);
      }
      // The instrument geometries: viewed along the normal, lit at 15, 45, 75 deg.
      if (std::acos(std::clamp(v.wo.z(), -1.0, 1.0)) <= tol) {
        const double theta_i = std::acos(std::clamp(v.wi.z(), -1.0, 1.0));
        for (std::size_t g = 0; g < kInstrumentAngles.size(); ++g)
          if (std::abs(theta_i - deg_to_rad(kInstrumentAngles[g])) <= tol) o.instrument |= static_cast<std::uint8_t>(1u << g);
      }
      all[v.pixel] = o;
      present[v.pixel] = 1;
    }, name(k));
    item->obs.reserve(all.size());
    for (std::size_t i = 0; i < all.size(); ++i)
      if (present[i]) item->obs.push_back(all[i]);
    return item;
  };

  // Stage 2, in sweep order: each pixel's runs of glints across the positions, and the sums.
  std::vector<PixelTrack> track(sampler.pixel_count());
  SweepAcc a(n_slices);
  auto close_run = [&](const PixelTrack& t) {  // one chord of run_len steps, in the slice where it lit up
    if (t.run_len <= 0 || t.run_slice < 0) return;
    SliceAcc& s = a.slices[static_cast<std::size_t>(t.run_slice)];
    s.runs += 1;
    s.chord_sum_rad += t.run_len * static_cast<double>(t.last_step);
  };
  Progress progress("flakes", static_cast<long>(count), "img");
  auto accumulate = [&](const Item& item) {
    const auto t = static_cast<std::int32_t>(item.index);
    if (item.index == 0) {
      out.mono = item.mono;
      out.colour_space = item.colour_space;
    }
    for (const Obs& o : item.obs) {
      PixelTrack& tr = track[o.pixel];
      if (tr.last_seen == t - 1) {
        tr.last_step = static_cast<float>(angle_between_units(tr.h.cast<double>(), o.h.cast<double>()));
        a.step_sum += tr.last_step;
        a.steps += 1;
      } else if (tr.run_len > 0) {  // a gap (an invalid position) ends a run unseen: left out
        tr.run_len = 0;
      }
      tr.last_seen = t;
      tr.h = o.h;
      SliceAcc& s = a.slices[o.slice];
      s.pixels += 1;
      if (o.glint) {
        s.glints.push_back({o.contrast, o.model_y, colour::Lab{o.lab[0], o.lab[1], o.lab[2]}});
        if (tr.last_glint == t - 1 && tr.run_len > 0) {
          tr.run_len += 1;
        } else {
          tr.run_len = 1;
          // A run lit at the first position began before the sweep: cut short, left out.
          tr.run_slice = t == 0 ? std::int16_t{-1} : static_cast<std::int16_t>(o.slice);
        }
        tr.last_glint = t;
      } else if (tr.run_len > 0) {
        close_run(tr);
        tr.run_len = 0;
      }
      for (std::size_t g = 0; g < kInstrumentAngles.size(); ++g) {
        if (!(o.instrument & (1u << g))) continue;
        InstrumentAcc& ia = a.instrument[g];
        ia.pixels += 1;
        if (o.glint) {
          ia.glints += 1;
          ia.contrast_sum += o.contrast;
        }
      }
    }
    out.images += 1;
    progress.step(fmt::format("{:.1f} deg", angle(item.index)));
  };
  // Images are read and compared in parallel (a few in flight), and tracked in order.
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    std::size_t next = 0;
    tbb::parallel_pipeline(
        static_cast<std::size_t>(2 * arena.max_concurrency()),
        tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                            [&](tbb::flow_control& fc) -> std::size_t {
                                              if (next >= count) {
                                                fc.stop();
                                                return 0;
                                              }
                                              return next++;
                                            }) &
            tbb::make_filter<std::size_t, std::shared_ptr<Item>>(tbb::filter_mode::parallel, observe) &
            tbb::make_filter<std::shared_ptr<Item>, void>(tbb::filter_mode::serial_in_order,
                                                          [&](const std::shared_ptr<Item>& item) { accumulate(*item); }));
  });
  // Runs still lit at the end of the sweep are cut short: left out like those cut by a gap.
  std::vector<SliceAcc>& slices = a.slices;
  const std::array<InstrumentAcc, 3>& instrument = a.instrument;
  const double step_sum = a.step_sum;
  const std::uint64_t steps = a.steps;
  out.step_deg = steps ? rad_to_deg(step_sum / static_cast<double>(steps)) : 0.0;
  double chord_all = 0.0;
  for (std::size_t i = 0; i < n_slices; ++i) {
    SliceAcc& a = slices[i];
    if (a.pixels == 0) continue;
    FlakeSlice s;
    s.theta_f = static_cast<int>(i % static_cast<std::size_t>(nf));
    s.theta_i = static_cast<int>(i / static_cast<std::size_t>(nf));
    s.pixels = a.pixels;
    s.glints = a.glints.size();
    s.runs = a.runs;
    s.lifetime_deg = a.runs ? rad_to_deg(2.0 / kPi * a.chord_sum_rad / static_cast<double>(a.runs)) : 0.0;
    if (!a.glints.empty()) {
      std::vector<float> c(a.glints.size());
      std::vector<colour::Lab> labs(a.glints.size());
      // Sorted by contrast first so that the colour list (and the octree's ties) do not
      // depend on the threads' order.
      std::sort(a.glints.begin(), a.glints.end(), [](const Glint& x, const Glint& y) {
        if (x.contrast != y.contrast) return x.contrast < y.contrast;
        if (x.lab.L != y.lab.L) return x.lab.L < y.lab.L;
        if (x.lab.a != y.lab.a) return x.lab.a < y.lab.a;
        return x.lab.b < y.lab.b;
      });
      double sum = 0.0, model_y = 0.0;
      for (std::size_t k = 0; k < a.glints.size(); ++k) {
        c[k] = a.glints[k].contrast;
        labs[k] = a.glints[k].lab;
        sum += c[k];
        model_y += a.glints[k].model_y;
      }
      s.intensity_mean = sum / static_cast<double>(c.size());
      s.glint_model_y = model_y / static_cast<double>(c.size());
      for (std::size_t q = 0; q < kQuantiles.size(); ++q)
        s.intensity_quantiles[q] = c[std::min(c.size() - 1, static_cast<std::size_t>(kQuantiles[q] * c.size()))];
      if (s.glints >= static_cast<std::uint64_t>(options.min_glints))
        cluster_flake_colours(labs, options.clusters, options.cdf_steps, &s.clusters, &s.inverse_cdf);
    }
    out.pixels += s.pixels;
    out.glints += s.glints;
    out.runs += s.runs;
    chord_all += a.chord_sum_rad;
    out.slices.push_back(std::move(s));
  }
  out.lifetime_deg = out.runs ? rad_to_deg(2.0 / kPi * chord_all / static_cast<double>(out.runs)) : 0.0;
  for (std::size_t g = 0; g < 3; ++g) {
    InstrumentSparkle is;
    is.illumination_deg = kInstrumentAngles[g];
    is.pixels = instrument[g].pixels;
    is.glints = instrument[g].glints;
    is.area_percent = is.pixels ? 100.0 * static_cast<double>(is.glints) / static_cast<double>(is.pixels) : 0.0;
    is.intensity = is.glints ? instrument[g].contrast_sum / static_cast<double>(is.glints) : 0.0;
    out.instrument.push_back(is);
  }
  return out;
}

}  // namespace

FlakeStats extract_flakes(const std::vector<HdrFrame>& frames, const calib::RigCalibration& calibration,
                          const brdf::Brdf& model, const FlakeOptions& options, const ExtractionOptions& extraction) {
  return extract_flakes_from(
      frames.size(), [&](std::size_t k) { return std::make_shared<const ExrImage>(read_exr(frames[k].path)); },
      [&](std::size_t k) { return frames[k].angle_deg; }, [&](std::size_t k) { return frames[k].path.string(); },
      calibration, model, options, extraction);
}

FlakeStats extract_flakes(const std::vector<std::pair<const ExrImage*, double>>& images,
                          const calib::RigCalibration& calibration, const brdf::Brdf& model, const FlakeOptions& options,
                          const ExtractionOptions& extraction) {
  return extract_flakes_from(
      images.size(), [&](std::size_t k) { return std::shared_ptr<const ExrImage>(images[k].first, [](const ExrImage*) {}); },
      [&](std::size_t k) { return images[k].second; }, [](std::size_t k) { return fmt::format("image {}", k); },
      calibration, model, options, extraction);
}

int FlakeBtf::slice_of(int f, int i) const {
  if (f < 0 || i < 0 || i >= max_theta_i || i + 1 >= static_cast<int>(slice_lut.size())) return -1;
  const int first = slice_lut[static_cast<std::size_t>(i)], limit = slice_lut[static_cast<std::size_t>(i) + 1];
  return first + f < limit ? first + f : -1;
}

void FlakeBtf::check(const std::string& where) const {
  if (num_theta_f < 1 || num_theta_i < 1 || num_theta_f * num_theta_i >= 256)
    throw DataError(fmt::format("{}: {} x {} slice bins (each >= 1, together below 256)", where, num_theta_f, num_theta_i));
  if (max_theta_i < 0 || max_theta_i > num_theta_i)
    throw DataError(fmt::format("{}: max_thetaI {} outside [0, {}]", where, max_theta_i, num_theta_i));
  if (slice_lut.size() != static_cast<std::size_t>(max_theta_i) + 1)
    throw DataError(fmt::format("{}: thetaFI_sliceLUT has {} entries, expected max_thetaI + 1 = {}", where,
                                slice_lut.size(), max_theta_i + 1));
  if (slice_lut.front() != 0) throw DataError(where + ": thetaFI_sliceLUT must start at 0");
  for (std::size_t k = 1; k < slice_lut.size(); ++k) {
    const int n = slice_lut[k] - slice_lut[k - 1];
    if (n < 0 || n > num_theta_f)
      throw DataError(fmt::format("{}: thetaFI_sliceLUT[{}] = {} after {}: theta_I bin {} would hold {} slices (0 to {})",
                                  where, k, slice_lut[k], slice_lut[k - 1], k - 1, n, num_theta_f));
  }
  if (slices() > 255) throw DataError(fmt::format("{}: {} slices; the 8-bit LUT holds at most 255", where, slices()));
  const std::size_t n = static_cast<std::size_t>(slices());
  const std::size_t t = static_cast<std::size_t>(texture_size);
  if (n > 0 && (texture_size < 1 || texture_size > 1024))
    throw DataError(fmt::format("{}: texture size {} outside [1, 1024]", where, texture_size));
  if (texels.size() != n * t * t * 3)
    throw DataError(fmt::format("{}: BTFflakes has {} values, expected {} slices x {} x {} x 3", where, texels.size(), n,
                                t, t));
  if (slice_mean.size() != n * 3)
    throw DataError(fmt::format("{}: slice_mean has {} values, expected {} slices x 3", where, slice_mean.size(), n));
  for (std::size_t k = 0; k < texels.size(); ++k)
    if (!(texels[k] >= 0.0) || !std::isfinite(texels[k]))
      throw DataError(fmt::format("{}: BTFflakes value {} at index {} is not a finite value >= 0", where, texels[k], k));
  if (!(ior >= 1.0 && ior <= 3.0)) throw DataError(fmt::format("{}: ior {} outside [1, 3]", where, ior));
}

FlakeBtf make_flake_btf(const FlakeStats& stats, int texture_size, std::uint64_t seed) {
  if (texture_size < 1 || texture_size > 1024)
    throw OptionError("flake BTF texture size", std::to_string(texture_size), "in [1, 1024]");
  FlakeBtf b;
  b.num_theta_f = stats.options.num_theta_f;
  b.num_theta_i = stats.options.num_theta_i;
  b.ior = stats.options.ior;
  b.texture_size = texture_size;
  // The theta_F range of each theta_I column: up to its last slice with a glint.
  std::vector<int> columns(static_cast<std::size_t>(b.num_theta_i), 0);
  for (const FlakeSlice& s : stats.slices)
    if (s.glints > 0) {
      auto& c = columns[static_cast<std::size_t>(s.theta_i)];
      c = std::max(c, s.theta_f + 1);
      b.max_theta_i = std::max(b.max_theta_i, s.theta_i + 1);
    }
  b.slice_lut.assign(1, 0);
  for (int i = 0; i < b.max_theta_i; ++i) b.slice_lut.push_back(b.slice_lut.back() + columns[static_cast<std::size_t>(i)]);
  const std::size_t t = static_cast<std::size_t>(texture_size), per = t * t * 3;
  b.texels.assign(static_cast<std::size_t>(b.slices()) * per, 0.0);
  b.slice_mean.assign(static_cast<std::size_t>(b.slices()) * 3, 0.0);
  for (const FlakeSlice& s : stats.slices) {
    const int k = b.slice_of(s.theta_f, s.theta_i);
    if (k < 0 || s.clusters.empty() || s.inverse_cdf.empty()) continue;
    std::mt19937_64 rng(seed ^ (0x9E3779B97F4A7C15ull * static_cast<std::uint64_t>(k + 1)));
    auto uniform = [&] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
    double* out = b.texels.data() + static_cast<std::size_t>(k) * per;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (std::size_t texel = 0; texel < t * t; ++texel) {
      const double u_area = uniform(), u_cluster = uniform(), u_lightness = uniform();
      if (u_area >= s.area()) continue;
      const std::size_t steps = s.inverse_cdf.size();
      const FlakeCluster& c = s.clusters[s.inverse_cdf[std::min(steps - 1, static_cast<std::size_t>(u_cluster * steps))]];
      // The contrast colour times the model's luminance at the slice's glints: the BRDF a glint adds.
      const colour::Rgb rgb = draw_flake_colour(c, u_lightness) * s.glint_model_y;
      for (int ch = 0; ch < 3; ++ch) out[texel * 3 + static_cast<std::size_t>(ch)] = rgb[ch];
      sum += rgb;
    }
    for (int ch = 0; ch < 3; ++ch)
      b.slice_mean[static_cast<std::size_t>(k) * 3 + static_cast<std::size_t>(ch)] = sum[ch] / static_cast<double>(t * t);
  }
  return b;
}

namespace {
double de76(const colour::Lab& x, const colour::Lab& y) {
  return std::sqrt((x.L - y.L) * (x.L - y.L) + (x.a - y.a) * (x.a - y.a) + (x.b - y.b) * (x.b - y.b));
}
}  // namespace

FlakeTransport flake_transport(const std::vector<FlakeCluster>& a, const std::vector<FlakeCluster>& b) {
  FlakeTransport out;
  if (a.empty() || b.empty()) return out;
  // Integer masses with the same total on both sides (the rounding goes to the largest).
  auto masses = [&](const std::vector<FlakeCluster>& c, const char* side) {
    double total = 0.0;
    for (const FlakeCluster& x : c) {
      if (!(x.probability >= 0.0)) throw DataError(fmt::format("flake colour transport: a cluster of {} has probability {}", side, x.probability));
      total += x.probability;
    }
    if (!(total > 0.0)) throw DataError(fmt::format("flake colour transport: the clusters of {} hold no probability", side));
    std::vector<long long> m(c.size());
    long long sum = 0;
    std::size_t largest = 0;
    for (std::size_t i = 0; i < c.size(); ++i) {
      m[i] = std::llround(c[i].probability / total * static_cast<double>(kFlakeTransportMass));
      sum += m[i];
      if (m[i] > m[largest]) largest = i;
    }
    m[largest] += kFlakeTransportMass - sum;
    return m;
  };
  const std::vector<long long> ma = masses(a, "the first slice"), mb = masses(b, "the second slice");
  lemon::SmartDigraph g;
  std::vector<lemon::SmartDigraph::Node> na, nb;
  std::vector<lemon::SmartDigraph::Arc> arcs;
  for (std::size_t i = 0; i < a.size(); ++i) na.push_back(g.addNode());
  for (std::size_t j = 0; j < b.size(); ++j) nb.push_back(g.addNode());
  lemon::SmartDigraph::ArcMap<long long> cost(g);
  lemon::SmartDigraph::NodeMap<long long> supply(g);
  for (std::size_t i = 0; i < a.size(); ++i) supply[na[i]] = ma[i];
  for (std::size_t j = 0; j < b.size(); ++j) supply[nb[j]] = -mb[j];
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = 0; j < b.size(); ++j) {
      const auto arc = g.addArc(na[i], nb[j]);
      arcs.push_back(arc);
      cost[arc] = std::llround(de76(a[i].mean, b[j].mean) * kFlakeTransportCostScale);
    }
  lemon::NetworkSimplex<lemon::SmartDigraph, long long, long long> ns(g);
  ns.costMap(cost).supplyMap(supply);
  if (ns.run() != lemon::NetworkSimplex<lemon::SmartDigraph, long long, long long>::OPTIMAL)
    throw DataError("flake colour transport: no optimal solution (unbalanced masses)");
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = 0; j < b.size(); ++j) {
      const long long f = ns.flow(arcs[i * b.size() + j]);
      if (f > 0) out.flows.push_back({i, j, static_cast<double>(f) / static_cast<double>(kFlakeTransportMass)});
    }
  // The cost of the flows at the exact distances (the solver's are rounded to 1e-6 dE).
  for (const FlakeTransport::Flow& f : out.flows) out.cost += f.mass * de76(a[f.from].mean, b[f.to].mean);
  return out;
}

double flake_colour_emd(const std::vector<FlakeCluster>& a, const std::vector<FlakeCluster>& b) {
  return flake_transport(a, b).cost;
}

std::vector<std::uint8_t> flake_inverse_cdf(const std::vector<FlakeCluster>& clusters, int steps) {
  std::vector<std::uint8_t> cdf;
  if (clusters.empty()) return cdf;
  if (clusters.size() > 256) throw DataError(fmt::format("flake clusters: {} clusters, at most 256 fit an inverse CDF", clusters.size()));
  cdf.resize(static_cast<std::size_t>(steps));
  double cum = 0.0;
  std::size_t c = 0;
  for (int k = 0; k < steps; ++k) {
    const double u = (k + 0.5) / steps;
    while (c + 1 < clusters.size() && cum + clusters[c].probability < u) cum += clusters[c++].probability;
    cdf[static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(c);
  }
  return cdf;
}

std::vector<FlakeCluster> flake_chromaticities(const std::vector<FlakeCluster>& clusters) {
  std::vector<FlakeCluster> out;
  for (const FlakeCluster& c : clusters) {
    const colour::Xyz xyz = colour::lab_to_xyz(c.mean, colour::d65());
    if (!(xyz[1] > 0.0)) continue;
    FlakeCluster n;
    n.mean = colour::xyz_to_lab(xyz / xyz[1], colour::d65());
    n.lo = n.hi = n.mean;
    n.probability = c.probability;
    n.count = c.count;
    out.push_back(n);
  }
  return out;
}

namespace {
std::uint64_t mix(std::uint64_t z) {  // splitmix64's finaliser
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
}  // namespace

namespace {
// The linear RGB of a CIELAB colour (white Y = 1).
Eigen::Vector3d rgb_of(const colour::Lab& lab) { return colour::xyz_to_srgb(colour::lab_to_xyz(lab, colour::d65())); }
double uniform_of(std::uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53; }
}  // namespace

Eigen::Vector3d draw_flake_colour(const FlakeCluster& c, double u) {
  const colour::Xyz mean = colour::lab_to_xyz(c.mean, colour::d65());
  if (!(mean[1] > 0.0)) return Eigen::Vector3d::Zero();
  const colour::Lab lightness{c.lo.L + u * (c.hi.L - c.lo.L), 0.0, 0.0};
  const double y = colour::lab_to_xyz(lightness, colour::d65())[1];
  return colour::xyz_to_srgb(mean / mean[1] * y).cwiseMax(0.0);
}

FlakeSparkle::FlakeSparkle(const FlakeStats& stats, std::uint64_t seed)
    : num_f_(stats.options.num_theta_f),
      num_i_(stats.options.num_theta_i),
      ior_(stats.options.ior),
      mono_(stats.mono),
      grid_rad_(2.0 * deg_to_rad(stats.lifetime_deg)),
      seed_(seed) {
  index_.assign(static_cast<std::size_t>(num_f_) * static_cast<std::size_t>(num_i_), -1);
  if (stats.empty()) return;
  if (!(stats.lifetime_deg > 0.0 && stats.lifetime_deg < 90.0))
    throw DataError(fmt::format("flake sparkle: lifetime {} deg outside (0, 90): too few glint runs to render from",
                                stats.lifetime_deg));
  for (const FlakeSlice& s : stats.slices) {
    if (s.clusters.empty() || s.inverse_cdf.empty() || s.glints == 0) continue;
    Slice sl;
    sl.area = s.area();
    sl.clusters = s.clusters;
    sl.inverse_cdf = s.inverse_cdf;
    for (const FlakeCluster& c : s.clusters) sl.mean_colour += c.probability * rgb_of(c.mean);
    index_[static_cast<std::size_t>(s.theta_i) * static_cast<std::size_t>(num_f_) + static_cast<std::size_t>(s.theta_f)] =
        static_cast<int>(slices_.size());
    slices_.push_back(std::move(sl));
  }
}

brdf::Rgb FlakeSparkle::delta(std::uint64_t cell, const Vec3& wi, const Vec3& wo, const brdf::Rgb& model) const {
  if (slices_.empty()) return brdf::Rgb::Zero();
  const auto bins = flake_slice_of(wi, wo, ior_, num_f_, num_i_);
  const int k = index_[static_cast<std::size_t>(bins[1]) * static_cast<std::size_t>(num_f_) + static_cast<std::size_t>(bins[0])];
  if (k < 0) return brdf::Rgb::Zero();
  const Slice& s = slices_[static_cast<std::size_t>(k)];
  const double y = mono_ ? model[0] : 0.2126 * model[0] + 0.7152 * model[1] + 0.0722 * model[2];
  if (!(y > 0.0)) return brdf::Rgb::Zero();
  // The half-vector cell: azimuthal-equidistant coordinates in units of the grid, offset
  // per surface cell.
  const Vec3 h = (wi + wo).normalized();
  const double theta = std::acos(std::clamp(h.z(), -1.0, 1.0)), phi = std::atan2(h.y(), h.x());
  const std::uint64_t c0 = mix(seed_ ^ mix(cell));
  const double ox = uniform_of(c0), oy = uniform_of(mix(c0));
  const auto gx = static_cast<std::int64_t>(std::floor(theta * std::cos(phi) / grid_rad_ + ox));
  const auto gy = static_cast<std::int64_t>(std::floor(theta * std::sin(phi) / grid_rad_ + oy));
  std::uint64_t r = mix(c0 ^ mix(static_cast<std::uint64_t>(gx) * 0x100000001B3ull ^ static_cast<std::uint64_t>(gy)));
  if (uniform_of(r) >= s.area) return brdf::Rgb(-s.area / (1.0 - s.area) * y * s.mean_colour.array());
  r = mix(r);
  const std::size_t steps = s.inverse_cdf.size();
  const FlakeCluster& c = s.clusters[s.inverse_cdf[std::min(steps - 1, static_cast<std::size_t>(uniform_of(r) * steps))]];
  const Eigen::Vector3d rgb = draw_flake_colour(c, uniform_of(mix(r))) * y;
  return mono_ ? brdf::Rgb::Constant(rgb[1]) : brdf::Rgb(rgb.array());
}

FlakeStats session_flakes(const acq::SessionDir& session, const brdf::Brdf& model, const FlakeOptions& options,
                          const ExtractionOptions& extraction, const std::optional<std::filesystem::path>& calib_dir) {
  // One look at the journal (it checks every image's checksum): the finished positions, or
  // the error naming the missing ones.
  const acq::SessionState state = session.inspect();
  if (!state.todo.empty()) acq::require_complete_session(session);
  std::vector<HdrFrame> frames;
  for (const auto& e : state.finished)
    if (e) frames.push_back({session.dir() / e->file, e->angle_deg});
  if (frames.empty()) throw DataError(session.dir().string() + ": the session has no finished light position");
  std::stable_sort(frames.begin(), frames.end(),
                   [](const HdrFrame& a, const HdrFrame& b) { return a.angle_deg < b.angle_deg; });
  const calib::RigCalibration cal = acq::session_calibration(session, calib_dir);
  spdlog::info("comparing {} HDR images of {} with the smooth model", frames.size(), session.dir().string());
  FlakeStats stats = extract_flakes(frames, cal, model, options, extraction);
  // The session states its values' colour space (its images may not).
  if (const std::string& cs = session.manifest().options.colour_space; !cs.empty()) stats.colour_space = cs;
  return stats;
}

FlakeStats session_flakes(const std::filesystem::path& session_dir, const SessionFlakeOptions& options) {
  options.flakes.check();
  const acq::SessionDir session = acq::SessionDir::open(session_dir);
  std::unique_ptr<brdf::Brdf> model;
  if (!options.fit_file.empty()) {
    model = brdf::make_brdf(load_any_paint(options.fit_file).paint_spec());
  } else {
    SessionBinOptions bin;
    bin.extraction = options.extraction;
    bin.calib_dir = options.calib_dir;
    model = brdf::make_brdf(fit_cook_torrance_now(load_fit_input(session_dir, bin), options.lobes,
                                                  session_dir.string()).paint_spec());
  }
  return session_flakes(session, *model, options.flakes, options.extraction, options.calib_dir);
}

namespace {

Json lab_json(const colour::Lab& c) { return Json::array({c.L, c.a, c.b}); }

colour::Lab lab_from(const Json& j, const std::string& where) {
  if (!j.is_array() || j.size() != 3 || !j[0].is_number() || !j[1].is_number() || !j[2].is_number())
    throw DataError(where + ": expected [L, a, b]");
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

}  // namespace

Json flakes_to_json(const FlakeStats& s) {
  const FlakeOptions& o = s.options;
  Json slices = Json::array();
  for (const FlakeSlice& sl : s.slices) {
    Json clusters = Json::array();
    for (const FlakeCluster& c : sl.clusters)
      clusters.push_back({{"p", c.probability}, {"n", c.count}, {"mean", lab_json(c.mean)}, {"lo", lab_json(c.lo)},
                          {"hi", lab_json(c.hi)}});
    Json q = Json::array();
    for (double v : sl.intensity_quantiles) q.push_back(v);
    slices.push_back({{"theta_f", sl.theta_f},
                      {"theta_i", sl.theta_i},
                      {"pixels", sl.pixels},
                      {"glints", sl.glints},
                      {"area", sl.area()},
                      {"intensity_mean", sl.intensity_mean},
                      {"glint_model_y", sl.glint_model_y},
                      {"intensity_quantiles", q},
                      {"runs", sl.runs},
                      {"lifetime_deg", sl.lifetime_deg},
                      {"clusters", clusters},
                      {"inverse_cdf", sl.inverse_cdf}});
  }
  Json instrument = Json::array();
  for (const InstrumentSparkle& is : s.instrument)
    instrument.push_back({{"illumination_deg", is.illumination_deg},
                          {"viewing_deg", 0.0},
                          {"pixels", is.pixels},
                          {"glints", is.glints},
                          {"sparkle_area_percent", is.measured() ? Json(is.area_percent) : Json(nullptr)},
                          {"sparkle_intensity", is.glints ? Json(is.intensity) : Json(nullptr)}});
  Json q = Json::array();
  for (double v : kQuantiles) q.push_back(v);
  return {{"format", kFlakesFormat},
          {"format_version", kFlakesFormatVersion},
          {"colour_space", s.colour_space},
          {"mono", s.mono},
          {"options",
           {{"ior", o.ior},
            {"num_theta_f", o.num_theta_f},
            {"num_theta_i", o.num_theta_i},
            {"bin_convention", kFlakeBinConvention},
            {"threshold_sigma", o.threshold_sigma},
            {"threshold_ratio", o.threshold_ratio},
            {"model_error", o.model_error},
            {"clusters", o.clusters},
            {"cdf_steps", o.cdf_steps},
            {"min_glints", o.min_glints},
            {"instrument_tolerance_deg", o.instrument_tolerance_deg}}},
          {"images", s.images},
          {"pixels", s.pixels},
          {"glints", s.glints},
          {"area", s.area()},
          {"empty", s.empty()},
          {"runs", s.runs},
          {"lifetime_deg", s.lifetime_deg},
          {"step_deg", s.step_deg},
          {"intensity_quantile_levels", q},
          {"instrument", instrument},
          {"slices", slices}};
}

FlakeStats flakes_from_json(const Json& j, const std::string& where) {
  if (!j.is_object() || j.value("format", std::string()) != kFlakesFormat)
    throw DataError(where + ": not a flakes file (format \"" + std::string(kFlakesFormat) + "\")");
  const int version = json_get<int>(j, "format_version", where);
  if (version > kFlakesFormatVersion)
    throw DataError(fmt::format("{}: format_version {} is newer than this software reads ({}): update paintlab", where,
                                version, kFlakesFormatVersion));
  FlakeStats s;
  const Json& o = j.at("options");
  const std::string ow = where + ": options";
  s.options.ior = json_get<double>(o, "ior", ow);
  s.options.num_theta_f = json_get<int>(o, "num_theta_f", ow);
  s.options.num_theta_i = json_get<int>(o, "num_theta_i", ow);
  s.options.threshold_sigma = json_get<double>(o, "threshold_sigma", ow);
  s.options.threshold_ratio = json_get<double>(o, "threshold_ratio", ow);
  s.options.model_error = json_get<double>(o, "model_error", ow);
  s.options.clusters = json_get<int>(o, "clusters", ow);
  s.options.cdf_steps = json_get<int>(o, "cdf_steps", ow);
  s.options.min_glints = json_get<int>(o, "min_glints", ow);
  s.options.instrument_tolerance_deg = json_get<double>(o, "instrument_tolerance_deg", ow);
  try {
    s.options.check();
  } catch (const OptionError& e) {
    throw DataError(ow + ": " + e.what());
  }
  s.colour_space = json_get<std::string>(j, "colour_space", where);
  s.mono = json_get<bool>(j, "mono", where);
  s.images = json_get<std::uint64_t>(j, "images", where);
  s.runs = json_get<std::uint64_t>(j, "runs", where);
  s.lifetime_deg = json_get<double>(j, "lifetime_deg", where);
  s.step_deg = json_get<double>(j, "step_deg", where);
  if (!j.contains("slices") || !j.at("slices").is_array()) throw DataError(where + ": slices: expected an array");
  std::size_t k = 0;
  for (const Json& js : j.at("slices")) {
    const std::string sw = fmt::format("{}: slices[{}]", where, k++);
    FlakeSlice sl;
    sl.theta_f = json_get<int>(js, "theta_f", sw);
    sl.theta_i = json_get<int>(js, "theta_i", sw);
    if (sl.theta_f < 0 || sl.theta_f >= s.options.num_theta_f || sl.theta_i < 0 || sl.theta_i >= s.options.num_theta_i)
      throw DataError(fmt::format("{}: bin ({}, {}) outside the {} x {} slices", sw, sl.theta_f, sl.theta_i,
                                  s.options.num_theta_f, s.options.num_theta_i));
    sl.pixels = json_get<std::uint64_t>(js, "pixels", sw);
    sl.glints = json_get<std::uint64_t>(js, "glints", sw);
    if (sl.glints > sl.pixels) throw DataError(sw + ": more glints than pixels");
    sl.intensity_mean = json_get<double>(js, "intensity_mean", sw);
    sl.glint_model_y = json_get<double>(js, "glint_model_y", sw);
    if (!(sl.glint_model_y >= 0.0)) throw DataError(sw + ": glint_model_y must be >= 0");
    const auto q = json_get<std::vector<double>>(js, "intensity_quantiles", sw);
    if (q.size() != sl.intensity_quantiles.size())
      throw DataError(fmt::format("{}: intensity_quantiles: expected {} values", sw, sl.intensity_quantiles.size()));
    std::copy(q.begin(), q.end(), sl.intensity_quantiles.begin());
    sl.runs = json_get<std::uint64_t>(js, "runs", sw);
    sl.lifetime_deg = json_get<double>(js, "lifetime_deg", sw);
    double p_sum = 0.0;
    std::size_t ci = 0;
    for (const Json& jc : js.at("clusters")) {
      const std::string cw = fmt::format("{}: clusters[{}]", sw, ci++);
      FlakeCluster c;
      c.probability = json_get<double>(jc, "p", cw);
      if (!(c.probability >= 0.0 && c.probability <= 1.0)) throw DataError(cw + ": p must be in [0, 1]");
      c.count = json_get<std::uint64_t>(jc, "n", cw);
      c.mean = lab_from(jc.at("mean"), cw + ": mean");
      c.lo = lab_from(jc.at("lo"), cw + ": lo");
      c.hi = lab_from(jc.at("hi"), cw + ": hi");
      p_sum += c.probability;
      sl.clusters.push_back(c);
    }
    if (!sl.clusters.empty() && std::abs(p_sum - 1.0) > 1e-6)
      throw DataError(fmt::format("{}: cluster probabilities sum to {:.9g}, not 1", sw, p_sum));
    const auto cdf = json_get<std::vector<int>>(js, "inverse_cdf", sw);
    for (int v : cdf)
      if (v < 0 || v >= static_cast<int>(sl.clusters.size()))
        throw DataError(fmt::format("{}: inverse_cdf entry {} names no cluster", sw, v));
    for (int v : cdf) sl.inverse_cdf.push_back(static_cast<std::uint8_t>(v));
    s.pixels += sl.pixels;
    s.glints += sl.glints;
    s.slices.push_back(std::move(sl));
  }
  for (const Json& ji : j.at("instrument")) {
    InstrumentSparkle is;
    is.illumination_deg = json_get<double>(ji, "illumination_deg", where + ": instrument");
    is.pixels = json_get<std::uint64_t>(ji, "pixels", where + ": instrument");
    is.glints = json_get<std::uint64_t>(ji, "glints", where + ": instrument");
    is.area_percent = ji.at("sparkle_area_percent").is_number() ? ji.at("sparkle_area_percent").get<double>() : 0.0;
    is.intensity = ji.at("sparkle_intensity").is_number() ? ji.at("sparkle_intensity").get<double>() : 0.0;
    s.instrument.push_back(is);
  }
  return s;
}

std::string describe_flakes(const FlakeStats& s) {
  std::string out = fmt::format(
      "{} images, {} pixel samples: {} glints (sparkle area {:.3f} %), {} glint runs, lifetime {:.2f} deg "
      "(half-vector step {:.2f} deg)\n",
      s.images, s.pixels, s.glints, 100.0 * s.area(), s.runs, s.lifetime_deg, s.step_deg);
  if (s.empty()) {
    out += "no glints: a paint without sparkle (the flake model is empty)\n";
  }
  out += "instrument-style sparkle (viewed along the normal):\n";
  for (const InstrumentSparkle& is : s.instrument) {
    if (!is.measured())
      out += fmt::format("  {:>4.0f} deg: not measured (no pixel within {:g} deg of that geometry)\n", is.illumination_deg,
                         s.options.instrument_tolerance_deg);
    else
      out += fmt::format("  {:>4.0f} deg: sparkle area {:.3f} %, intensity {:.2f} ({} of {} pixel samples)\n",
                         is.illumination_deg, is.area_percent, is.intensity, is.glints, is.pixels);
  }
  std::vector<const FlakeSlice*> busiest;
  for (const FlakeSlice& sl : s.slices)
    if (sl.glints > 0) busiest.push_back(&sl);
  std::sort(busiest.begin(), busiest.end(), [](const FlakeSlice* a, const FlakeSlice* b) { return a->glints > b->glints; });
  if (!busiest.empty()) out += "slices with the most glints (theta_F, theta_I bins of 90/N deg):\n";
  for (std::size_t k = 0; k < std::min<std::size_t>(5, busiest.size()); ++k) {
    const FlakeSlice& sl = *busiest[k];
    out += fmt::format("  ({:2d}, {:2d}): area {:.3f} %, intensity {:.2f} (median {:.2f}), {} colour clusters, "
                       "lifetime {:.2f} deg\n",
                       sl.theta_f, sl.theta_i, 100.0 * sl.area(), sl.intensity_mean, sl.intensity_quantiles[2],
                       sl.clusters.size(), sl.lifetime_deg);
  }
  return out;
}

}  // namespace paintlab::fit
