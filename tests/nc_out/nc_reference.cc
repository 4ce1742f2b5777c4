// The test side's reference for what the NC interpolates: nc_reference.h.
#include "tests/nc_out/nc_reference.h"

#include <Eigen/Sparse>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>
#include <regex>
#include <sstream>

#include <gtest/gtest.h>

namespace gaugeloop::testing {

RefTable ref_parse(const std::string& program, char axis) {
  RefTable t;
  std::istringstream in(program);
  std::string line;
  bool inside = false;
  // The leading axis: C, or a correction layer's virtual axis written SIM1=<value>.
  const std::regex point(std::string(R"((?:C|SIM1=)(-?[0-9]+\.[0-9]+) )") + axis + R"((-?[0-9]+\.[0-9]+))");
  const std::string num = R"((-?[0-9]+\.[0-9]+))";
  const std::regex poly(R"(PO\[C\]=\()" + num + R"(\) PO\[)" + std::string(1, axis) + R"(\]=\()" + num + "," + num +
                        "," + num + R"(\))");
  while (std::getline(in, line)) {
    if (line.rfind("CTABDEF", 0) == 0) {
      inside = true;
      continue;
    }
    if (line.rfind("CTABEND", 0) == 0) break;
    if (!inside) continue;
    if (line.find("CSPLINE") != std::string::npos) t.spline = true;
    std::smatch m;
    if (std::regex_search(line, m, poly)) {
      t.poly = true;
      t.c.push_back(std::stod(m[1]));
      t.x.push_back(std::stod(m[2]));
      t.a2.push_back(std::stod(m[3]));
      t.a3.push_back(std::stod(m[4]));
    } else if (std::regex_search(line, m, point)) {
      t.c.push_back(std::stod(m[1]));
      t.x.push_back(std::stod(m[2]));
      t.a2.push_back(0.0);
      t.a3.push_back(0.0);
    }
  }
  return t;
}

std::function<double(double)> ref_interpolant(const RefTable& t) {
  const int n = static_cast<int>(t.c.size());
  std::vector<double> slope(static_cast<size_t>(n), 0.0);
  if (t.spline) {
    // Natural spline in first derivatives m_i: 2 m_0 + m_1 = 3 d_0;
    // h_i m_{i-1} + 2 (h_{i-1} + h_i) m_i + h_{i-1} m_{i+1} = 3 (h_i d_{i-1} + h_{i-1} d_i);
    // m_{n-2} + 2 m_{n-1} = 3 d_{n-2}; d the chord slopes, h the widths.
    auto h = [&](int i) { return t.c[static_cast<size_t>(i + 1)] - t.c[static_cast<size_t>(i)]; };
    auto d = [&](int i) { return (t.x[static_cast<size_t>(i + 1)] - t.x[static_cast<size_t>(i)]) / h(i); };
    std::vector<Eigen::Triplet<double>> a;
    Eigen::VectorXd rhs(n);
    a.emplace_back(0, 0, 2.0);
    a.emplace_back(0, 1, 1.0);
    rhs(0) = 3.0 * d(0);
    for (int i = 1; i + 1 < n; ++i) {
      a.emplace_back(i, i - 1, h(i));
      a.emplace_back(i, i, 2.0 * (h(i - 1) + h(i)));
      a.emplace_back(i, i + 1, h(i - 1));
      rhs(i) = 3.0 * (h(i) * d(i - 1) + h(i - 1) * d(i));
    }
    a.emplace_back(n - 1, n - 2, 1.0);
    a.emplace_back(n - 1, n - 1, 2.0);
    rhs(n - 1) = 3.0 * d(n - 2);
    Eigen::SparseMatrix<double> m(n, n);
    m.setFromTriplets(a.begin(), a.end());
    Eigen::SparseLU<Eigen::SparseMatrix<double>> lu;
    lu.compute(m);
    EXPECT_EQ(lu.info(), Eigen::Success);
    Eigen::VectorXd s = lu.solve(rhs);
    for (int i = 0; i < n; ++i) slope[static_cast<size_t>(i)] = s(i);
  }
  return [t, slope](double c) {
    // A periodic table is read modulo its range (a table that starts on the base circle).
    const double range = t.c.back() - t.c.front();
    if (c < t.c.front()) c += range;
    if (c > t.c.back()) c -= range;
    size_t i = static_cast<size_t>(std::upper_bound(t.c.begin(), t.c.end(), c) - t.c.begin());
    i = std::min(i == 0 ? 0 : i - 1, t.c.size() - 2);
    const double h = t.c[i + 1] - t.c[i];
    const double u = (c - t.c[i]) / h;
    if (t.poly) {
      // f(u) = a0 + a1 u + a2 u^2 + a3 u^3 from the segment's start, a1 such that f(1) is its end.
      const double a2 = t.a2[i + 1], a3 = t.a3[i + 1];
      const double a1 = t.x[i + 1] - t.x[i] - a2 - a3;
      return t.x[i] + a1 * u + a2 * std::pow(u, 2) + a3 * std::pow(u, 3);
    }
    if (!t.spline) return t.x[i] + (t.x[i + 1] - t.x[i]) * u;
    // Cubic Hermite on [c_i, c_i+1] with the spline's slopes.
    const double h00 = 2 * u * u * u - 3 * u * u + 1, h10 = u * u * u - 2 * u * u + u;
    const double h01 = -2 * u * u * u + 3 * u * u, h11 = u * u * u - u * u;
    return h00 * t.x[i] + h10 * h * slope[i] + h01 * t.x[i + 1] + h11 * h * slope[i + 1];
  };
}

double ref_error_um(const std::string& program, const SampledPath& path, double* at_c_deg) {
  const RefTable t = ref_parse(program);
  EXPECT_GE(t.c.size(), 3u);
  const auto nc = ref_interpolant(t);
  double worst = -1.0;
  const size_t n = path.x_mm.size();
  for (size_t j = 0; j <= n; ++j) {
    const double c = j == n ? 360.0 : static_cast<double>(j) * path.c_step_deg;
    const double e = std::abs(nc(c) - path.x_mm[j % n]) * 1000.0;
    if (e > worst) {
      worst = e;
      if (at_c_deg) *at_c_deg = c;
    }
  }
  return worst;
}

}  // namespace gaugeloop::testing
