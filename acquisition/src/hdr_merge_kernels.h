#pragma once
// The inner loops of the HDR merge (hdr_merge.cpp), compiled once for the x86-64 baseline and
// once for AVX2 + FMA (hdr_merge_kernels.cpp); kernels() picks the best one this CPU runs.
//
// Every value (pixel x channel) accumulates, over the frames of a bracket and in their order,
//   acc += tv_j * entry            tv_j = {t_j, t_j^2, t_j^2, 0}
// where entry = {w y, w, w^2 var, b} comes from a table: per raw value without a dark map
// (b = 0), per integer dark-subtracted value u with one (b = w (y(u + 1) - y(u)), the slope to
// the next integer; then tv_j = {t_j, t_j^2, t_j^2, t_j frac_j}, frac_j the fractional part of
// u_j), so that  s1 = acc[0] + acc[3] = sum w t y,  s2 = acc[1] = sum w t^2,
// s3 = acc[2] = sum w^2 t^2 var.
// The batch merge runs all frames of a block at once with the accumulators in registers; the
// streaming merge runs one frame at a time on stored accumulators: the same operations in the
// same order, so both give the same bits.
#include <cstddef>
#include <cstdint>

namespace paintlab::acq::detail {

typedef float Float4 __attribute__((vector_size(16)));
typedef int Int4 __attribute__((vector_size(16)));

// Lanes I0..I3 of the eight lanes of (a, b): GCC's and clang's builtins for the same shuffle.
template <int I0, int I1, int I2, int I3>
inline Float4 shuffle_lanes(Float4 a, Float4 b) {
#if defined(__clang__)
  return __builtin_shufflevector(a, b, I0, I1, I2, I3);
#else
  return __builtin_shuffle(a, b, Int4{I0, I1, I2, I3});
#endif
}

// Values per block: whole RGB pixels and a multiple of the vector width.
inline constexpr std::size_t kBlockValues = 240;

struct MergeTables {
  int channels = 1;
  // Without a dark map: entry of raw value z of channel c at codes[c * 65536 + z].
  const Float4* codes = nullptr;
  // With a dark map: x = z - (bias + rate t) - u_lo clamped to [0, top], entry of channel c at
  // dark_lut[c * dark_stride + floor(x)], interpolated with frac = x - floor(x); raw values at
  // or above `saturation` use the all-zero entry `zero`.
  const Float4* dark_lut = nullptr;
  std::size_t dark_stride = 0;
  const float* bias = nullptr;  // per value
  const float* rate = nullptr;  // per value
  float u_lo = 0.0f;
  float top = 0.0f;
  float saturation = 0.0f;
  int zero = 0;
  // Byte offset of channel (k mod 3)'s table for the k-th value of a block (RGB with a dark map).
  const int* channel_offset = nullptr;
};

struct Frame {
  const std::uint16_t* z = nullptr;
  Float4 tv = {0.0f, 0.0f, 0.0f, 0.0f};  // {t, t^2, t^2, 0}
  float t = 0.0f;
};

inline Frame make_frame(const std::uint16_t* z, double exposure_s) {
  const float t = static_cast<float>(exposure_s);
  const float t2 = t * t;
  return Frame{z, Float4{t, t2, t2, 0.0f}, t};
}

struct Kernels {
  const char* name;
  // Values [v0, v0 + m) (whole pixels, m <= kBlockValues), frames in order, into acc[0..m).
  // `off` and `tf` are scratch of frames x kBlockValues.
  void (*accumulate)(const MergeTables& tables, const Frame* frames, std::size_t nframes, std::size_t v0,
                     std::size_t m, Float4* acc, int* off, float* tf);
};

// The best kernels for this CPU, and the baseline ones (any x86-64).
const Kernels& kernels();
const Kernels& baseline_kernels();

}  // namespace paintlab::acq::detail
