#pragma once
// Hole filling of a half-vector table (models.md "Half-vector table", Günther et al.:
// empty bins get a weighted sum of their neighbours), as a push-pull pyramid (Gortler et
// al., "The Lumigraph", 1996) in log space over the 90 x 90 x 180 grid:
//  1. reciprocity: an isotropic, reciprocal BRDF has f(theta_h, theta_d, phi_d) =
//     f(theta_h, theta_d, pi - phi_d), so an empty bin whose mirror bin 179 - k is
//     measured takes the mirror's value;
//  2. push: each coarser level averages the log values of its (up to 8) children,
//     weighted by their confidence; a level's confidence is min(1, sum of children's);
//  3. pull: from the coarsest level down, every cell of confidence w < 1 becomes
//     w * own + (1 - w) * trilinear interpolation of the next coarser level.
// Log space keeps the fill smooth across the orders of magnitude near the peak. Only bins
// whose centre has both directions above the horizon are filled; the others stay Empty.
// Filled bins are marked BinState::Filled and keep count 0, so fits and reports never
// count them as measurements.
#include <cstddef>

#include "paintlab/brdf/merl.h"

namespace paintlab::fit {

// Nothing to check: a flag has no invalid value.
struct HoleFillOptions {
  bool use_reciprocity = true;  // step 1
};

struct HoleFillReport {
  std::size_t measured_bins = 0;    // measured bins with positive values (the data)
  std::size_t filled_mirror = 0;    // filled from the phi_d mirror bin
  std::size_t filled_pyramid = 0;   // filled by push-pull
  std::size_t invalid_empty = 0;    // bins below the horizon, left empty
  int levels = 0;                   // pyramid levels including the full grid
};

// Fills the empty valid bins of `table` in place. Throws DataError ("the table has no
// measured bins with positive values: nothing to fill from") when there is no data.
HoleFillReport fill_holes(brdf::MerlTable& table, const HoleFillOptions& options = {});

}  // namespace paintlab::fit
