// The HDR merge kernels for the x86-64 baseline and, on x86-64 with GCC, for AVX2 + FMA (a
// #pragma GCC target region: the same source, compiled for the wider instruction set, chosen at
// run time when the CPU has it; a rig computer without it runs the baseline).
#include "hdr_merge_kernels.h"

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define PAINTLAB_HDR_AVX2 1
#include <immintrin.h>
#else
#define PAINTLAB_HDR_AVX2 0
#endif

namespace paintlab::acq::detail {

namespace base {
#define PAINTLAB_HDR_FMA 0
#include "hdr_merge_kernels.inc"
#undef PAINTLAB_HDR_FMA
}  // namespace base

#if PAINTLAB_HDR_AVX2
#pragma GCC push_options
#pragma GCC target("avx2,fma")
namespace avx2 {
#define PAINTLAB_HDR_FMA 1
#include "hdr_merge_kernels.inc"
#undef PAINTLAB_HDR_FMA
}  // namespace avx2
#pragma GCC pop_options
#endif

const Kernels& baseline_kernels() {
#if defined(__x86_64__)
  static const Kernels k{"x86-64", &base::accumulate};
#else
  static const Kernels k{"generic", &base::accumulate};
#endif
  return k;
}

const Kernels& kernels() {
#if PAINTLAB_HDR_AVX2
  static const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  static const Kernels k{"avx2+fma", &avx2::accumulate};
  if (avx2) return k;
#endif
  return baseline_kernels();
}

}  // namespace paintlab::acq::detail
