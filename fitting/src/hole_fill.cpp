#include "paintlab/fitting/hole_fill.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "fit_util.h"
#include "paintlab/core/error.h"
#include "paintlab/fitting/coverage.h"

namespace paintlab::fit {

namespace {

struct Level {
  int n0 = 0, n1 = 0, n2 = 0;  // theta_h, theta_d, phi_d
  std::vector<float> log_value;  // 3 per cell
  std::vector<float> weight;     // confidence in [0, 1]

  Level(int a, int b, int c)
      : n0(a), n1(b), n2(c), log_value(3 * static_cast<std::size_t>(a) * b * c, 0.0f),
        weight(static_cast<std::size_t>(a) * b * c, 0.0f) {}
  std::size_t index(int i, int j, int k) const {
    return (static_cast<std::size_t>(i) * n1 + j) * n2 + k;
  }
};

void push(const Level& fine, Level& coarse) {
  tbb::parallel_for(0, coarse.n0, [&](int I) {
    for (int J = 0; J < coarse.n1; ++J)
      for (int K = 0; K < coarse.n2; ++K) {
        float wsum = 0, l[3] = {0, 0, 0};
        for (int a = 0; a < 2; ++a) {
          const int i = 2 * I + a;
          if (i >= fine.n0) break;
          for (int b = 0; b < 2; ++b) {
            const int j = 2 * J + b;
            if (j >= fine.n1) break;
            for (int c = 0; c < 2; ++c) {
              const int k = 2 * K + c;
              if (k >= fine.n2) break;
              const std::size_t f = fine.index(i, j, k);
              const float w = fine.weight[f];
              if (w <= 0.0f) continue;
              wsum += w;
              for (int ch = 0; ch < 3; ++ch) l[ch] += w * fine.log_value[3 * f + ch];
            }
          }
        }
        const std::size_t q = coarse.index(I, J, K);
        if (wsum > 0.0f) {
          for (int ch = 0; ch < 3; ++ch) coarse.log_value[3 * q + ch] = l[ch] / wsum;
          coarse.weight[q] = std::min(1.0f, wsum);
        }
      }
  });
}

// Position of fine cell x in the coarse grid (cell centres), clamped, as (index, fraction).
void coarse_coord(int x, int n_coarse, int& x0, float& f) {
  float c = 0.5f * static_cast<float>(x) - 0.25f;
  c = std::clamp(c, 0.0f, static_cast<float>(n_coarse - 1));
  x0 = std::min(static_cast<int>(c), std::max(n_coarse - 2, 0));
  f = c - static_cast<float>(x0);
  if (n_coarse == 1) f = 0.0f;
}

void pull(const Level& coarse, Level& fine) {
  tbb::parallel_for(0, fine.n0, [&](int i) {
    int i0;
    float fi;
    coarse_coord(i, coarse.n0, i0, fi);
    const int i1 = std::min(i0 + 1, coarse.n0 - 1);
    for (int j = 0; j < fine.n1; ++j) {
      int j0;
      float fj;
      coarse_coord(j, coarse.n1, j0, fj);
      const int j1 = std::min(j0 + 1, coarse.n1 - 1);
      for (int k = 0; k < fine.n2; ++k) {
        const std::size_t q = fine.index(i, j, k);
        const float w = fine.weight[q];
        if (w >= 1.0f) continue;
        int k0;
        float fk;
        coarse_coord(k, coarse.n2, k0, fk);
        const int k1 = std::min(k0 + 1, coarse.n2 - 1);
        float up[3] = {0, 0, 0};
        const int ia[2] = {i0, i1}, ja[2] = {j0, j1}, ka[2] = {k0, k1};
        const float wi[2] = {1 - fi, fi}, wj[2] = {1 - fj, fj}, wk[2] = {1 - fk, fk};
        for (int a = 0; a < 2; ++a)
          for (int b = 0; b < 2; ++b)
            for (int c = 0; c < 2; ++c) {
              const float t = wi[a] * wj[b] * wk[c];
              if (t == 0.0f) continue;
              const std::size_t s = coarse.index(ia[a], ja[b], ka[c]);
              for (int ch = 0; ch < 3; ++ch) up[ch] += t * coarse.log_value[3 * s + ch];
            }
        for (int ch = 0; ch < 3; ++ch) fine.log_value[3 * q + ch] = w * fine.log_value[3 * q + ch] + (1 - w) * up[ch];
        fine.weight[q] = 1.0f;
      }
    }
  });
}

}  // namespace

HoleFillReport fill_holes(brdf::MerlTable& table, const HoleFillOptions& options) {
  HoleFillReport rep;
  const auto& valid = valid_bin_mask();

  auto positive = [&](std::size_t b) {
    if (table.state(b) != brdf::BinState::Measured) return false;
    const brdf::Rgb v = table.value(b);
    return v[0] > 0.0 && v[1] > 0.0 && v[2] > 0.0;
  };

  std::vector<std::pair<std::size_t, std::size_t>> mirror_fills;  // (empty bin, source)
  for (std::size_t b = 0; b < kMerlBins; ++b) {
    if (positive(b)) ++rep.measured_bins;
  }
  if (rep.measured_bins == 0)
    throw DataError("the table has no measured bins with positive values: nothing to fill holes from");

  if (options.use_reciprocity) {
    for (std::size_t b = 0; b < kMerlBins; ++b) {
      if (!valid[b] || table.state(b) != brdf::BinState::Empty) continue;
      const std::size_t k = b % kMerlPhiD;
      const std::size_t mirror = b - k + (kMerlPhiD - 1 - k);
      if (positive(mirror)) mirror_fills.emplace_back(b, mirror);
    }
    for (const auto& [b, src] : mirror_fills) table.set_value(b, table.value(src), brdf::BinState::Filled);
    rep.filled_mirror = mirror_fills.size();
  }

  std::vector<Level> levels;
  levels.emplace_back(kMerlThetaH, kMerlThetaD, kMerlPhiD);
  {
    Level& l0 = levels.front();
    for (std::size_t b = 0; b < kMerlBins; ++b) {
      const bool data = positive(b) || (table.state(b) == brdf::BinState::Filled && (table.value(b) > 0.0).all());
      if (!data) continue;
      const brdf::Rgb v = table.value(b);
      for (int ch = 0; ch < 3; ++ch) l0.log_value[3 * b + ch] = static_cast<float>(std::log(v[ch]));
      l0.weight[b] = 1.0f;
    }
  }
  while (levels.back().n0 > 1 || levels.back().n1 > 1 || levels.back().n2 > 1) {
    const Level& f = levels.back();
    Level c((f.n0 + 1) / 2, (f.n1 + 1) / 2, (f.n2 + 1) / 2);
    push(f, c);
    levels.push_back(std::move(c));
  }
  rep.levels = static_cast<int>(levels.size());
  for (std::size_t l = levels.size() - 1; l > 0; --l) pull(levels[l], levels[l - 1]);

  const Level& l0 = levels.front();
  for (std::size_t b = 0; b < kMerlBins; ++b) {
    if (table.state(b) != brdf::BinState::Empty) continue;
    if (!valid[b]) {
      ++rep.invalid_empty;
      continue;
    }
    table.set_value(b,
                    brdf::Rgb(std::exp(l0.log_value[3 * b]), std::exp(l0.log_value[3 * b + 1]),
                              std::exp(l0.log_value[3 * b + 2])),
                    brdf::BinState::Filled);
    ++rep.filled_pyramid;
  }
  return rep;
}

}  // namespace paintlab::fit
