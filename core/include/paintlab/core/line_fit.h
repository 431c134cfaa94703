#pragma once
// Weighted least squares of a straight line y = intercept + slope * x, accumulated one point
// at a time (a dark frame's level against exposure time, the response's noise variance
// against signal level).
namespace paintlab {

class WeightedLineFit {
 public:
  void add(double x, double y, double weight = 1.0) {
    sw_ += weight;
    sx_ += weight * x;
    sy_ += weight * y;
    sxx_ += weight * x * x;
    sxy_ += weight * x * y;
  }
  // Whether the points determine a line: positive total weight at two or more distinct x.
  bool determined() const { return determinant() > 0.0; }
  // The slope; 0 when the line is not determined.
  double slope() const { return determined() ? (sw_ * sxy_ - sx_ * sy_) / determinant() : 0.0; }
  // The value at x = 0 (with slope 0 when not determined: the weighted mean); NaN without
  // points.
  double intercept() const { return (sy_ - slope() * sx_) / sw_; }
  // The weighted mean of y (NaN without points).
  double mean_y() const { return sy_ / sw_; }

 private:
  double determinant() const { return sw_ * sxx_ - sx_ * sx_; }
  double sw_ = 0, sx_ = 0, sy_ = 0, sxx_ = 0, sxy_ = 0;
};

}  // namespace paintlab
