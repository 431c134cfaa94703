#include "paintlab/sim/paint.h"

#include <algorithm>
#include <string>

#include "paintlab/brdf/carpaint.h"
#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/brdf/pearlescent.h"
#include "paintlab/core/error.h"

namespace paintlab::sim {

namespace {

// The glitter term of a layered pearlescent paint as a BRDF of its own.
class GlitterPart final : public brdf::Brdf {
 public:
  explicit GlitterPart(std::shared_ptr<const brdf::LayeredPearlescent> paint) : paint_(std::move(paint)) {}
  brdf::Rgb eval(const brdf::Vec3& wi, const brdf::Vec3& wo) const override { return paint_->eval_glitter(wi, wo); }
  std::string model() const override { return "layered-pearlescent-glitter"; }

 private:
  std::shared_ptr<const brdf::LayeredPearlescent> paint_;
};

// The lobes listed in `which` (carried = true) or the others (carried = false).
template <class Lobe>
std::vector<Lobe> pick_lobes(const std::vector<Lobe>& all, const std::vector<int>& which, const std::string& name,
                             bool carried = true) {
  for (int i : which)
    if (i < 0 || static_cast<std::size_t>(i) >= all.size())
      throw DataError("paint '" + name + "': flakes carry lobe " + std::to_string(i + 1) + ", which does not exist");
  std::vector<Lobe> out;
  for (std::size_t i = 0; i < all.size(); ++i) {
    bool listed = std::find(which.begin(), which.end(), static_cast<int>(i)) != which.end();
    if (listed == carried) out.push_back(all[i]);
  }
  return out;
}

}  // namespace

SimPaint sim_paint(const brdf::PaintSpec& spec) {
  SimPaint out;
  std::shared_ptr<const brdf::Brdf> full = brdf::make_brdf(spec);
  out.brdf = full;
  if (!spec.flakes) return out;
  const brdf::FlakeSpec& fl = *spec.flakes;
  Sparkle sp;
  sp.density = fl.density;
  sp.roughness = fl.roughness;
  sp.lifetime_deg = fl.lifetime_deg;
  sp.colour = {fl.tint_sd, fl.interference, fl.interference_chroma, fl.interference_shift_deg};
  if (const auto* ct = spec.cook_torrance()) {
    sp.flake_part = std::make_shared<brdf::CookTorrance>(brdf::Rgb::Zero(), pick_lobes(ct->lobes, fl.lobes, spec.name));
    sp.steady_part = std::make_shared<brdf::CookTorrance>(ct->kd, pick_lobes(ct->lobes, fl.lobes, spec.name, false));
  } else if (const auto* axf = spec.axf_carpaint()) {
    brdf::AxfCarPaintParams p = *axf;
    p.diffuse = 0.0;
    p.lobes = pick_lobes(axf->lobes, fl.lobes, spec.name);
    sp.flake_part = std::make_shared<brdf::AxfCarPaint>(std::move(p));
    brdf::AxfCarPaintParams rest = *axf;
    rest.lobes = pick_lobes(axf->lobes, fl.lobes, spec.name, false);
    sp.steady_part = std::make_shared<brdf::AxfCarPaint>(std::move(rest));
  } else if (spec.pearlescent()) {
    auto pearl = std::dynamic_pointer_cast<const brdf::LayeredPearlescent>(full);
    if (!pearl) throw DataError("paint '" + spec.name + "': expected a layered-pearlescent model");
    sp.flake_part = std::make_shared<GlitterPart>(pearl);
  } else {
    throw DataError("paint '" + spec.name + "': sparkle needs an analytic model with lobes or glitter, not \"" +
                    spec.model() + "\"");
  }
  out.sparkle = sp;
  return out;
}

SimPaint load_sim_paint(const std::filesystem::path& paint_file) { return sim_paint(brdf::load_paint_file(paint_file)); }

SimPaint reference_paint(double albedo) {
  if (!(albedo >= 0 && albedo <= 1)) throw DataError("reference paint: albedo must be in [0, 1]");
  return {std::make_shared<brdf::Lambertian>(brdf::Rgb::Constant(albedo)), std::nullopt};
}

SimPaint glossy_black_sphere_paint() {
  brdf::CtLobe lobe;
  lobe.ks = brdf::Rgb(0.6, 0.6, 0.6);
  lobe.m = 0.03;
  lobe.r = 0.05;
  return {std::make_shared<brdf::CookTorrance>(brdf::Rgb(0.01, 0.01, 0.01), std::vector<brdf::CtLobe>{lobe}),
          std::nullopt};
}

}  // namespace paintlab::sim
