// Linear least squares for the fits of the folder: the one place Eigen's QR and SVD are
// instantiated (compiled once, not in every file that fits something).
#pragma once

#include <Eigen/Core>
#include <vector>

namespace gaugeloop {

// The least-squares solution of a x = y, by QR with column pivoting: it holds when columns are
// nearly collinear (a short arc's cosine beside the constant).
Eigen::VectorXd least_squares(const Eigen::MatrixXd& a, const Eigen::VectorXd& y);

// A fit of error terms whose columns come in different units (um, um per mm, ms): each column is
// scaled to unit norm first, so that the singular values say what the data can tell apart
// whatever the units.
struct ScaledFit {
  // For each singular value of the scaled matrix below 1e-9 of the largest, its right singular
  // vector: the combination of columns the data does not see. Empty when every column is
  // separable; a column's weight above 1e-6 in one of them names it unseparable.
  std::vector<Eigen::VectorXd> null_directions;
  // The fit in the columns' own units (least squares on the scaled matrix, scaled back).
  Eigen::VectorXd x;
  // Largest over smallest singular value of the scaled matrix; 0 when the smallest is 0.
  double condition = 0.0;
};

// Fits a x = y as above. `a` must have at least one row and one column.
ScaledFit scaled_least_squares(const Eigen::MatrixXd& a, const Eigen::VectorXd& y);

}  // namespace gaugeloop
