#pragma once
// BRDF samples as extraction produces them and binning consumes them: one sample per
// sphere pixel and light position, in Rusinkiewicz coordinates (models.md "Frames and
// angles") with its RGB value in 1/sr and the noise variance of that value.
// Structure of arrays, so binning runs through memory linearly.
#include <cstddef>
#include <vector>

namespace paintlab::fit {

struct SampleBatch {
  std::vector<double> theta_h;  // radians, [0, pi/2]
  std::vector<double> theta_d;  // radians, [0, pi/2]
  std::vector<double> phi_d;    // radians, [-pi, pi] (phi_d and phi_d + pi are the same bin)
  std::vector<float> value;     // 3 per sample (R, G, B), 1/sr
  std::vector<float> variance;  // 3 per sample, (1/sr)^2 noise variance; empty = unknown

  std::size_t size() const { return theta_h.size(); }
  bool empty() const { return theta_h.empty(); }
  bool has_variance() const { return !variance.empty(); }
  void clear();
  void reserve(std::size_t n, bool with_variance);
  void push_back(double th, double td, double pd, float r, float g, float b);
  void push_back(double th, double td, double pd, const float rgb[3], const float var[3]);
  // Appends another batch (both with or both without variance).
  void append(const SampleBatch& other);
  // Aborts with a message when the arrays disagree in length (a programming error).
  void check_consistent() const;
};

}  // namespace paintlab::fit
