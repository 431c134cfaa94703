#pragma once
// Designing paints from measured ones (docs/design.md): Golla and Klein's interpolation of
// metallic car paints ("Interactive Interpolation of Metallic Effect Car Paints", VMV 2018).
// The analytic parameters interpolate linearly, the colour table in CIELAB, and the flake
// colour clusters of each slice are matched by optimal transport (CIELAB distance of the
// cluster means as the cost; flake_transport, an exact network simplex): every flow becomes
// an interpolatable cluster whose mean and cuboid corners move linearly from its cluster in
// the first paint to its cluster in the second, carrying the flow's mass. A realisation at
// weights (wA, wB) is then a few multiply-adds per cluster. Weights outside [0, 1] extrapolate;
// three or more paints interpolate by iterated transport (their section 4.3): the first two,
// then the result with the third, and so on.
#include <functional>
#include <string>
#include <vector>

#include "paintlab/core/json.h"

#include "paintlab/fitting/axf_file.h"
#include "paintlab/fitting/flakes.h"

namespace paintlab::fit {

// A flow of the transport: the cluster `from` of the first paint's slice moving to the
// cluster `to` of the second's, carrying `mass` of the slice's probability.
struct InterpolatableCluster {
  FlakeCluster from, to;
  std::size_t from_index = 0, to_index = 0;  // in the parents' slices
  double mass = 0.0;
};

// One (theta_F, theta_I) slice of two paints. A slice with glints in one paint only keeps
// that paint's colours (nothing to move them towards) while its area interpolates.
struct InterpolatableSlice {
  int theta_f = 0, theta_i = 0;
  FlakeSlice a, b;                            // the parents' slices (their scalars)
  std::vector<InterpolatableCluster> clusters;
  double transport_cost = 0.0;                // dE76 x mass: the slice's colour EMD
};

// Two paints ready to realise at any weights (computed once: the transports).
struct InterpolatablePaint {
  AxfPaint a, b;
  std::vector<InterpolatableSlice> slices;    // slices measured in both paints
  std::vector<std::string> notes;             // what was left out, and why
};

// DataError with the reason when the two cannot interpolate: different colour spaces,
// a cosine-lobes paint, models without a common form, Cook-Torrance forms with different lobe counts, colour
// tables of different sizes, flake slices of different layouts (num_theta_F / num_theta_I /
// ior), or flakes in one paint only.
InterpolatablePaint interpolatable_paint(const AxfPaint& a, const AxfPaint& b);

// The part of an interpolatable paint that costs (the transports; the rest is the parents'):
// {"format": "paintlab-flake-transports", "version": 1, "slices": [{"theta_f", "theta_i",
// "cost", "flows": [[from, to, mass], ...]}, ...]}, one entry per slice with colours in both.
inline constexpr const char* kTransportsFormat = "paintlab-flake-transports";
Json transports_to_json(const InterpolatablePaint& m);
// interpolatable_paint with the transports read from `transports` (transports_to_json's object)
// instead of computed: the same checks, and DataError naming `where` when they do not belong to
// these two paints (a slice missing, a cluster index out of range, a cluster's flows not
// carrying its probability, the stored cost not the flows' cost).
InterpolatablePaint interpolatable_paint(const AxfPaint& a, const AxfPaint& b, const Json& transports,
                                         const std::string& where);

// How the flake clusters' colours interpolate (the paper's section 4.4): all of CIELAB, only
// their lightness L* (a*, b* stay the first paint's: `--flakes-lightness-only`), or all but
// their lightness (L* stays the first paint's: `--keep-flake-lightness`).
enum class FlakeColourMode { All, LightnessOnly, KeepLightness };

struct RealisedPaint {
  AxfPaint paint;
  // Values an extrapolation took outside what a paint can hold, each named with its value
  // before it was clamped ("cook_torrance lobe 2 m -0.04 -> 0.001").
  std::vector<std::string> clamped;
  std::vector<std::string> notes;  // InterpolatablePaint::notes of the transports made
};
// The paint wA A + wB B (wA + wB = 1 interpolates; other weights are the caller's choice).
// With `flake_btf` the flake BTF is drawn again from the realised statistics at the texture
// size of the first parent's (most of a realisation's time; a slider previewing through
// FlakeSparkle needs only the statistics). Provenance: source "interpolation: A wA, B wB"; the fit quality is dropped (no
// measurement was fitted), and so are the parents' cosine-lobe weights (a note says so).
RealisedPaint realise(const InterpolatablePaint& m, double wa, double wb, bool flake_btf = true,
                      FlakeColourMode flake_colour = FlakeColourMode::All);

struct InterpolateOptions {
  std::string name;           // of the result (default: the parents' names and weights)
  bool free_weights = false;  // weights need not sum to 1
  // With a mode other than All the first paint leads the iterated transports (its flakes'
  // hue or lightness is what is kept); the rest follow by falling weight.
  FlakeColourMode flake_colour = FlakeColourMode::All;
  // Makes the first pair's interpolatable paint (default: interpolatable_paint): a library
  // hands out its cached transports here (PaintLibrary::interpolatable).
  std::function<InterpolatablePaint(const AxfPaint&, const AxfPaint&)> first_pair = {};
};
// Any number (2 to 5) of parents: iterated transport, the paints taken in order of falling
// weight (the first paint first with a flake colour mode). DataError naming --weights when the weights are not one per paint, or do not sum to
// 1 (within 1e-9) without free_weights, or (free weights) when the largest ones sum to 0.
RealisedPaint interpolate_paints(const std::vector<AxfPaint>& parents, const std::vector<double>& weights,
                                 const InterpolateOptions& options = {});

}  // namespace paintlab::fit
