// Least squares: QR with column pivoting, and the singular values of the column-scaled matrix.
#include "compensation/least_squares.h"

#include <Eigen/Dense>

namespace gaugeloop {

Eigen::VectorXd least_squares(const Eigen::MatrixXd& a, const Eigen::VectorXd& y) {
  return a.colPivHouseholderQr().solve(y);
}

ScaledFit scaled_least_squares(const Eigen::MatrixXd& a, const Eigen::VectorXd& y) {
  const Eigen::Index columns = a.cols();
  Eigen::VectorXd scale(columns);
  for (Eigen::Index c = 0; c < columns; ++c) {
    const double norm = a.col(c).norm();
    scale(c) = norm > 0.0 ? 1.0 / norm : 1.0;
  }
  const Eigen::MatrixXd an = a * scale.asDiagonal();
  // V (the null directions) and the singular values are all that is read: no U.
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(an, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  ScaledFit fit;
  const double largest = sv.size() > 0 ? sv(0) : 0.0;
  for (Eigen::Index i = 0; i < sv.size(); ++i) {
    if (sv(i) <= 1e-9 * largest) fit.null_directions.push_back(svd.matrixV().col(i));
  }
  const double smallest = sv.size() > 0 ? sv(sv.size() - 1) : 0.0;
  fit.condition = smallest > 0.0 ? largest / smallest : 0.0;
  fit.x = scale.asDiagonal() * least_squares(an, y);
  return fit;
}

}  // namespace gaugeloop
