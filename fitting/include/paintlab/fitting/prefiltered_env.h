#pragma once
// Rendering a cosine-lobe paint under an environment map by one prefiltered map per exponent
// (docs/design.md "Rendering the basis"; the 2005 source's real-time rendering):
//   P_E(d) = integral over the sphere of L(w) max(0, d.w)^E dw      (E = 1: the irradiance)
// and for a surface of normal n seen from v, with rv = 2 (n.v) n - v the mirror direction,
//   radiance = kd / pi P_1(n) + sum_i (kg_i + (n.v) kdd_i) P_Ei(rv)
// The kg terms are exact but for light from below the horizon, which P_E counts (only near the
// silhouette, where the lobe reaches past it); the kdd terms take (n.wi) at the lobe's centre,
// (n.rv) = (n.v), which the narrow lobes make exact and the broad ones approximate.
//
// Each map is equirectangular in the preview's convention (preview.h), its height about
// 2 pi sqrt(E) texels (a lobe of width 1/sqrt(E) rad is spanned by a few texels; 16 to the
// source map's height), built from the source map box-filtered to twice that, summing each
// output texel's lobe over the source texels where (d.w)^E > 1e-4 with the kernel normalised
// to its exact integral 2 pi / (E + 1) (a lobe a few texels wide otherwise gains or loses up to
// 7 %, measured at E = 800 on a 64-row map). Maps are cached on disk
// (cached()), keyed by the SHA-256 of the EXR, the intensity and the exponents: computed once
// per map.
#include <filesystem>
#include <vector>

#include "paintlab/brdf/brdf.h"
#include "paintlab/brdf/cosine_lobes.h"
#include "paintlab/core/image.h"
#include "paintlab/fitting/preview.h"

namespace paintlab::fit {

class PrefilteredEnvironment {
 public:
  // Builds the irradiance map and one map per exponent from `env`.
  static PrefilteredEnvironment build(const EnvironmentMap& env, const std::vector<double>& exponents);
  // The maps of `exr` (times `intensity`) for `exponents` from `cache_dir` when they are there,
  // else built and stored there (atomically; a cache that cannot be written is only a warning).
  // *from_cache tells which.
  static PrefilteredEnvironment cached(const std::filesystem::path& exr, double intensity,
                                       const std::vector<double>& exponents, const std::filesystem::path& cache_dir,
                                       bool* from_cache = nullptr);
  // $XDG_CACHE_HOME/paintlab/prefiltered, else $HOME/.cache/paintlab/prefiltered.
  static std::filesystem::path default_cache_dir();

  const std::vector<double>& exponents() const { return exponents_; }
  brdf::Rgb irradiance(const brdf::Vec3& n) const { return lookup(maps_[0], n); }
  brdf::Rgb lobe(std::size_t i, const brdf::Vec3& d) const { return lookup(maps_[i + 1], d); }
  const ImageF& map(std::size_t k) const { return maps_[k]; }  // 0: irradiance, then per exponent

  // Bilinear lookup of an equirectangular map (wraps in azimuth, clamps at the poles).
  static brdf::Rgb lookup(const ImageF& map, const brdf::Vec3& d);
  // The same at map coordinates u, v in [0, 1) (uv_of(d)): one direction's trigonometry serves
  // every map.
  static brdf::Rgb lookup_uv(const ImageF& map, double u, double v);
  static void uv_of(const brdf::Vec3& d, double* u, double* v);

 private:
  std::vector<double> exponents_;
  std::vector<ImageF> maps_;
};

// The preview scene (preview.h) of a cosine-lobe paint: the point light (options.point_light)
// by the model itself, the environment by the prefiltered maps, which must hold the paint's
// exponents (DataError otherwise). options.environment is not read.
Preview render_preview_cosine(const brdf::CosineLobeParams& paint, const PreviewOptions& options,
                              const PrefilteredEnvironment* env);

}  // namespace paintlab::fit
