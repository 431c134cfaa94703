#pragma once
// Robust statistics: medians, the median absolute deviation (MAD), quantiles. The one place
// for them; calibration and fitting call these instead of their own copies.
//
// The values are any contiguous range of numbers (std::vector, std::span, a C array); the
// result is a double. Empty input gives NaN from every function. NaN values are not handled:
// std::nth_element needs a strict weak order, so callers leave NaN out (with NaN in the
// input the result is unspecified). The *_inplace functions reorder (and upper_mad_inplace
// overwrites) the caller's values and save the copy the others make.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numeric>
#include <ranges>
#include <string>
#include <type_traits>
#include <vector>

#include "paintlab/core/error.h"

namespace paintlab {

// MAD -> standard deviation for normally distributed data: 1 / Phi^-1(3/4) =
// 1 / 0.674490 = 1.482602 (the normal-consistency factor, Rousseeuw & Croux, JASA 88 (1993)
// 1273), rounded to the four decimals every calibration result so far was computed with.
inline constexpr double kMadToSigma = 1.4826;

namespace detail {
template <class R>
using RangeElement = std::remove_reference_t<std::ranges::range_reference_t<R>>;
}  // namespace detail

// A contiguous range of numbers, const or not.
template <class R>
concept NumberRange = std::ranges::contiguous_range<R> && std::ranges::sized_range<R> &&
    std::is_arithmetic_v<std::remove_cv_t<detail::RangeElement<R>>>;
// ... whose elements may be reordered and overwritten.
template <class R>
concept MutableNumberRange = NumberRange<R> && !std::is_const_v<detail::RangeElement<R>>;

namespace detail {

template <class R>
std::vector<std::remove_cv_t<RangeElement<R>>> copy_of(const R& values) {
  return {std::ranges::begin(values), std::ranges::end(values)};
}

template <class T>
double upper_median_of(T* first, std::size_t n) {
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  T* mid = first + n / 2;
  std::nth_element(first, mid, first + n);
  return static_cast<double>(*mid);
}

inline void check_fraction(double q, const char* what) {
  if (!(q >= 0.0 && q <= 1.0))
    throw DataError(std::string(what) + ": q = " + std::to_string(q) + ". Violated constraint: 0 <= q <= 1");
}

}  // namespace detail

// ---- medians ----

// The median: for an odd count the middle value, for an even count std::midpoint of the two
// middle values (their mean, without overflow). Works on a copy.
template <NumberRange R>
double median(const R& values) {
  auto v = detail::copy_of(values);
  const std::size_t n = v.size();
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(n / 2);
  std::nth_element(v.begin(), mid, v.end());
  const double hi = static_cast<double>(*mid);
  if (n % 2 == 1) return hi;
  return std::midpoint(static_cast<double>(*std::max_element(v.begin(), mid)), hi);
}

// The upper median: the element at index n/2 of the sorted values, i.e. the middle value for
// an odd count and the upper of the two middle values for an even count (no averaging: the
// result is always one of the values). Works on a copy.
template <NumberRange R>
double upper_median(const R& values) {
  auto v = detail::copy_of(values);
  return detail::upper_median_of(v.data(), v.size());
}

// upper_median() of `values`, which it reorders (std::nth_element).
template <MutableNumberRange R>
double upper_median_inplace(R&& values) {
  return detail::upper_median_of(std::ranges::data(values), std::ranges::size(values));
}

// ---- median absolute deviation ----

// The MAD about `centre` of `values`, which it overwrites with |x - centre| (in their order)
// and reorders: upper_median(|x - centre|), the differences formed in the element type
// (float values give float differences, with centre rounded to float). Times kMadToSigma it
// estimates the standard deviation of normal data. Floating-point values only.
template <MutableNumberRange R>
double upper_mad_inplace(R&& values, double centre) {
  using T = std::remove_cv_t<detail::RangeElement<R>>;
  static_assert(std::is_floating_point_v<T>, "upper_mad: floating-point values only");
  for (auto& x : values) x = std::abs(x - static_cast<T>(centre));
  return upper_median_inplace(values);
}

// upper_mad_inplace() on a copy.
template <NumberRange R>
double upper_mad(const R& values, double centre) {
  auto v = detail::copy_of(values);
  return upper_mad_inplace(v, centre);
}

// ---- quantiles ----
// q is a fraction; DataError when it is not in [0, 1] (NaN included), whatever the values.

// The q-quantile interpolated linearly between the order statistics x(0) <= ... <= x(n-1):
// with h = q (n - 1) and j = floor(h), x(j) + (h - j) (x(j+1) - x(j)); x(j) itself when h is a
// whole number. q = 0 gives the minimum, q = 1 the maximum, q = 1/2 the median of an odd
// count (Hyndman & Fan, Am. Stat. 50 (1996) 361, definition 7; R's and NumPy's default).
// Works on a copy.
template <NumberRange R>
double quantile(const R& values, double q) {
  detail::check_fraction(q, "quantile");
  auto v = detail::copy_of(values);
  const std::size_t n = v.size();
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  const double h = q * static_cast<double>(n - 1);
  const auto j = static_cast<std::size_t>(h);
  auto it = v.begin() + static_cast<std::ptrdiff_t>(j);
  std::nth_element(v.begin(), it, v.end());
  const double lo = static_cast<double>(*it);
  const double frac = h - static_cast<double>(j);
  if (frac == 0.0) return lo;
  const double hi = static_cast<double>(*std::min_element(it + 1, v.end()));
  return lo + frac * (hi - lo);
}

// The lower q-quantile: the order statistic x(k) with k = floor(q (n - 1)), no interpolation
// (NumPy's method "lower"; the result is always one of the values). Reorders `values`.
template <MutableNumberRange R>
double lower_quantile_inplace(R&& values, double q) {
  detail::check_fraction(q, "lower_quantile_inplace");
  const std::size_t n = std::ranges::size(values);
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  auto* first = std::ranges::data(values);
  auto* kth = first + static_cast<std::size_t>(q * static_cast<double>(n - 1));
  std::nth_element(first, kth, first + n);
  return static_cast<double>(*kth);
}

}  // namespace paintlab
