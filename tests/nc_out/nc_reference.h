// Test-side reference for what the NC interpolates, written apart from nc_out's own code:
// reads the table blocks from the program TEXT with a regex and evaluates G1 as chords,
// CSPLINE (BNAT ENAT) as the natural cubic spline solved in slopes (not moments) with
// Eigen's sparse LU, and POLY as the manual's polynomial in p = 0..1, so a mistake in the
// writer's evaluation cannot hide in both. Compiled once (nc_reference.cc).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "nc_out/sampled_path.h"

namespace gaugeloop::testing {

struct RefTable {
  bool spline = false;
  bool poly = false;
  std::vector<double> c;
  std::vector<double> x;
  std::vector<double> a2, a3;  // POLY: the segment ending at each point (0 for the first)
};

// Blocks between CTABDEF and CTABEND: `C<number> <axis><number>` (X, or Y for a crankpin's Y
// table; a correction layer's `SIM1=<number> X<number>`), CSPLINE anywhere switches mode;
// POLY blocks `PO[C]=(c) PO[<axis>]=(x,a2,a3)`.
RefTable ref_parse(const std::string& program, char axis = 'X');

// What the NC makes of the table at C. A failed solve is a test failure (EXPECT).
std::function<double(double)> ref_interpolant(const RefTable& t);

// Largest |NC - exact| over the fine rows 0 .. n (row n: C360 against row 0), in um.
double ref_error_um(const std::string& program, const SampledPath& path, double* at_c_deg = nullptr);

}  // namespace gaugeloop::testing
