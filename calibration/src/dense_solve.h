#pragma once
// The calibration's small dense least-squares problems (a corner, a silhouette, a highlight,
// the LED circle, the intrinsics' refinement) are solved one way: Ceres, silent, on the
// calling thread (the callers run over images in parallel themselves), with the limits each
// problem needs.
#include <ceres/ceres.h>

namespace paintlab::calib {

inline ceres::Solver::Summary solve_dense(ceres::Problem& problem, int max_iterations, double function_tolerance,
                                          double parameter_tolerance,
                                          double gradient_tolerance = 1e-10,  // Ceres' default
                                          ceres::LinearSolverType solver = ceres::DENSE_QR) {
  ceres::Solver::Options so;
  so.linear_solver_type = solver;
  so.max_num_iterations = max_iterations;
  so.function_tolerance = function_tolerance;
  so.parameter_tolerance = parameter_tolerance;
  so.gradient_tolerance = gradient_tolerance;
  so.logging_type = ceres::SILENT;
  so.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  return summary;
}

}  // namespace paintlab::calib
