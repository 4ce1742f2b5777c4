// Table writers on a path with known answers.
#include "nc_out/table_writer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "nc_out/table_program.h"
#include "tests/nc_out/analytic_path.h"
#include "tests/nc_out/nc_reference.h"

namespace gaugeloop {
namespace {

using testing::analytic_path;
using testing::kRadPerDeg;

constexpr CurveTableFormat kSixDecimals{3, 1e6};  // X to 1e-6 mm: rounding far below the checks

std::string program_of(const CurveTable& t, const CurveTableFormat& format = kSixDecimals) {
  Result<std::string> p = render_table_program("{{table_header}}\nCTABDEF(X,C,1,1)\n{{table_blocks}}\nCTABEND\nM17\n",
                                               "t.spf", {}, t, {1, 1}, format);
  EXPECT_TRUE(p.ok()) << p.error().message;
  return p.ok() ? *p : "";
}

// Chords of a cos C: the chord over [c - h/2, c + h/2] misses by a cos(c) (1 - cos(h/2)) at
// its middle, largest for the segment next to C0: a cos(h/2) (1 - cos(h/2)). Tolerance
// 1e-3 um: X is written to 1e-6 mm, so each point is off by up to 5e-4 um.
TEST(TableWriter, LinearErrorIsTheChordErrorOfACosine) {
  const double a = 5.0;
  const SampledPath p = analytic_path(a, 0.0);
  for (double h : {1.0, 0.5, 2.0}) {
    Result<CurveTable> t = write_linear_table(p, h, kSixDecimals);
    ASSERT_TRUE(t.ok()) << t.error().message;
    const double half = h / 2.0 * kRadPerDeg;
    EXPECT_NEAR(t->error.max_abs_um, a * std::cos(half) * (1.0 - std::cos(half)) * 1000.0, 1e-3) << h;
    EXPECT_EQ(t->block_count(), static_cast<int>(std::lround(360.0 / h)) + 1);
    EXPECT_EQ(t->points.back().c_deg, 360.0);
    EXPECT_EQ(t->points.back().x_mm, t->points.front().x_mm);
  }
}

// The writer's figure against the test's own regex reading of the program and its own
// spline (slopes, sparse LU). Tolerance 1e-4 um: same points, two exact solves.
TEST(TableWriter, EveryWriterAgreesWithAnIndependentEvaluation) {
  const SampledPath p = analytic_path(4.0, 0.7);
  const AdaptiveSettings adaptive{0.5, 10.0};
  for (Result<CurveTable> t : {write_linear_table(p, 1.0), write_spline_table(p, 2.0), write_spline_table(p, 5.0),
                               write_adaptive_linear_table(p, adaptive), write_adaptive_spline_table(p, adaptive)}) {
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_NEAR(t->error.max_abs_um, testing::ref_error_um(program_of(*t, {}), p), 1e-4) << t->writer;
  }
}

// The scan read (X alone, walking on from the last segment) is the full read's X to the last
// bit, for every interpolation, for C in order, backwards, on the points, outside the range
// (read modulo it) and after a jump: the writers judge tables with it. Exact equality.
TEST(TableInterpolantTest, XAloneIsTheFullReadsXBitForBit) {
  const SampledPath p = analytic_path(4.0, 0.7);
  const std::vector<Result<CurveTable>> tables = {write_linear_table(p, 1.0), write_spline_table(p, 5.0),
                                                  write_poly_table(p, 2.0),
                                                  write_adaptive_spline_table(p, {0.5, 10.0})};
  std::vector<double> cs;
  for (int k = 0; k <= 36000; ++k) cs.push_back(k * 0.01);                              // the fine rows, in order
  for (int k = 7200; k >= 0; k -= 7) cs.push_back(k * 0.05 - 0.005);                    // backwards, off the grid
  for (double c : {-725.3, 360.0, 1080.25, 12.0, 359.999, 0.0, -0.0}) cs.push_back(c);  // outside, jumps
  for (const Result<CurveTable>& t : tables) {
    ASSERT_TRUE(t.ok()) << t.error().message;
    Result<TableInterpolant> nc = TableInterpolant::of(t->points, t->interpolation);
    ASSERT_TRUE(nc.ok()) << nc.error().message;
    for (const CurvePoint& point : t->points) cs.push_back(point.c_deg);
    std::size_t scan = 0;
    std::size_t full = 0;
    int differing = 0;
    for (double c : cs) {
      const double x = nc->x_mm_at(c, scan);
      const double expected = nc->at(c, full).x_mm;
      if (std::memcmp(&x, &expected, sizeof x) != 0 && ++differing <= 3) {
        ADD_FAILURE() << t->writer << ": C" << c << " X " << x << " against " << expected;
      }
      EXPECT_EQ(nc->at(c).x_mm, expected) << t->writer << " C" << c;  // the hint changes nothing
    }
    EXPECT_EQ(differing, 0) << t->writer;
  }
}

TEST(TableWriter, AdaptiveKeepsTheBoundWithFewerBlocksThanUniform) {
  const SampledPath p = analytic_path(4.0, 0.7);
  for (double bound : {0.5, 2.0}) {
    Result<CurveTable> lin = write_adaptive_linear_table(p, {bound, 10.0});
    Result<CurveTable> spl = write_adaptive_spline_table(p, {bound, 10.0});
    ASSERT_TRUE(lin.ok() && spl.ok());
    EXPECT_LE(lin->error.max_abs_um, bound);
    EXPECT_LE(spl->error.max_abs_um, bound);
    // The uniform G1 table that keeps the bound needs more blocks.
    for (double h : {1.0, 0.5, 0.25, 0.2, 0.1}) {
      Result<CurveTable> u = write_linear_table(p, h);
      ASSERT_TRUE(u.ok());
      if (u->error.max_abs_um <= bound) {
        EXPECT_LT(lin->block_count(), u->block_count()) << h;
        break;
      }
    }
    EXPECT_LT(spl->block_count(), lin->block_count());
  }
}

TEST(TableWriter, NoSegmentIsWiderThanTheWidestStep) {
  const SampledPath p = analytic_path(4.0, 0.0);  // nearly straight near C90 and C270
  for (Result<CurveTable> t :
       {write_adaptive_linear_table(p, {5.0, 3.0}), write_adaptive_spline_table(p, {5.0, 3.0})}) {
    ASSERT_TRUE(t.ok()) << t.error().message;
    for (size_t i = 1; i < t->points.size(); ++i) {
      EXPECT_LE(t->points[i].c_deg - t->points[i - 1].c_deg, 3.0 + 1e-9) << t->writer << " at C" << t->points[i].c_deg;
    }
  }
}

TEST(TableWriter, RefusesAStepThatDoesNotFitTheGrid) {
  const SampledPath p = analytic_path(4.0, 0.7);
  for (double h : {0.7, 0.005, 0.0, -1.0}) {
    Result<CurveTable> t = write_linear_table(p, h);
    ASSERT_FALSE(t.ok()) << h;
    EXPECT_EQ(t.error().code, ErrorCode::kInvalidInput);
  }
}

// At the control's default MD10200 (1000 increments/mm) every X lies on the 1 um grid, the
// program carries 3 decimals, and the reported error is that of the rounded points: a
// 0.1 deg G1 table misses a 4 mm cosine by 0.002 um between points, the rounding by up to
// 0.5 um.
TEST(TableWriter, AtOneMicronResolutionPointsAreOnTheGridAndTheErrorIncludesTheRounding) {
  const SampledPath p = analytic_path(4.0, 0.7);
  const CurveTableFormat um{3, 1000.0};
  Result<CurveTable> coarse = write_linear_table(p, 0.1, um);
  Result<CurveTable> fine = write_linear_table(p, 0.1, kSixDecimals);
  ASSERT_TRUE(coarse.ok() && fine.ok());
  for (const CurvePoint& pt : coarse->points) {
    EXPECT_NEAR(pt.x_mm * 1000.0, std::round(pt.x_mm * 1000.0), 1e-9) << "C" << pt.c_deg;
  }
  EXPECT_LT(fine->error.max_abs_um, 0.01);
  EXPECT_GT(coarse->error.max_abs_um, 0.4) << "the rounding to 1 um is part of the command error";
  EXPECT_LE(coarse->error.max_abs_um, 0.5 + fine->error.max_abs_um + 1e-9);
  const std::string program = program_of(*coarse, um);
  EXPECT_NE(program.find("\nG1 C0.000 X0.000\n"), std::string::npos) << program.substr(0, 600);
  EXPECT_NEAR(coarse->error.max_abs_um, testing::ref_error_um(program, p), 1e-4);
}

// A resolution that is not a power of ten: X on the increment (1/3000 mm), not on a decimal;
// written with 4 decimals, which the control reads back as the same increment.
TEST(TableWriter, RoundsToAnIncrementThatIsNotAPowerOfTen) {
  const SampledPath p = analytic_path(4.0, 0.7);
  const CurveTableFormat third{3, 3000.0};
  EXPECT_EQ(third.x_decimals(), 4);
  Result<CurveTable> t = write_spline_table(p, 2.0, third);
  ASSERT_TRUE(t.ok()) << t.error().message;
  bool off_decimal_grid = false;
  for (const CurvePoint& pt : t->points) {
    EXPECT_NEAR(pt.x_mm * 3000.0, std::round(pt.x_mm * 3000.0), 1e-7) << "C" << pt.c_deg;
    off_decimal_grid |= std::abs(pt.x_mm * 1e4 - std::round(pt.x_mm * 1e4)) > 1e-3;
  }
  EXPECT_TRUE(off_decimal_grid) << "rounded to 4 decimals, not to the 1/3000 mm increment";
  // The text is within 0.05 um of each increment; the errors agree to that.
  EXPECT_NEAR(t->error.max_abs_um, testing::ref_error_um(program_of(*t, third), p), 0.06);
}

TEST(TableWriter, RefusesAResolutionTheControlCannotHave) {
  const SampledPath p = analytic_path(4.0, 0.7);
  for (double incr : {0.0, 0.5, 2500.5, 2e6, std::nan("")}) {
    Result<CurveTable> t = write_linear_table(p, 1.0, CurveTableFormat{3, incr});
    ASSERT_FALSE(t.ok()) << incr;
    EXPECT_EQ(t.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(t.error().message.find("MD10200"), std::string::npos) << t.error().message;
  }
}

TEST(TableWriter, RefusesAPathOfTheWrongShape) {
  SampledPath p = analytic_path(4.0, 0.7);
  p.dx_dc_mm_per_deg.pop_back();
  Result<CurveTable> t = write_linear_table(p, 1.0);
  ASSERT_FALSE(t.ok());
  EXPECT_EQ(t.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(t.error().message.find("36000 rows"), std::string::npos) << t.error().message;
}

TEST(DefaultTable, PicksTheFewestBlocksThatKeepTheBound) {
  const SampledPath p = analytic_path(4.0, 0.7);
  Result<CurveTable> d = write_default_table(p, {});
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_LE(d->error.max_abs_um, 0.5);
  Result<CurveTable> spl = write_adaptive_spline_table(p, {0.5, 10.0});
  Result<CurveTable> lin = write_adaptive_linear_table(p, {0.5, 10.0});
  ASSERT_TRUE(spl.ok() && lin.ok());
  EXPECT_EQ(d->block_count(), std::min(spl->block_count(), lin->block_count()));
  EXPECT_EQ(d->interpolation, Interpolation::kCubicSpline);
}

TEST(DefaultTable, WithoutSplinesPicksALinearTable) {
  const SampledPath p = analytic_path(4.0, 0.7);
  Result<CurveTable> d = write_default_table(p, {0.5, 10.0, false});
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_EQ(d->interpolation, Interpolation::kLinear);
  EXPECT_LE(d->error.max_abs_um, 0.5);
}

TEST(DefaultTable, RefusesWhenNothingKeepsTheBound) {
  const SampledPath p = analytic_path(4.0, 0.7);
  // X written to 0.1 um cannot keep 0.01 um.
  Result<CurveTable> d = write_default_table(p, {0.01, 10.0, true});
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.error().code, ErrorCode::kRefused);
  EXPECT_NE(d.error().message.find("0.010 um"), std::string::npos) << d.error().message;
}

// The path plus a local correction: a bump of `height_um` at C180, `width_deg` wide (the
// width of a Gaussian's 1/e point), with its exact derivatives.
SampledPath with_bump(SampledPath p, double height_um, double width_deg) {
  for (size_t i = 0; i < p.x_mm.size(); ++i) {
    const double u = (static_cast<double>(i) * p.c_step_deg - 180.0) / width_deg;
    const double g = height_um / 1000.0 * std::exp(-u * u);
    p.x_mm[i] += g;
    p.dx_dc_mm_per_deg[i] += g * (-2.0 * u / width_deg);
    p.d2x_dc2_mm_per_deg2[i] += g * (4.0 * u * u - 2.0) / (width_deg * width_deg);
  }
  return p;
}

TablePointsInForce points_of(const CurveTable& t) {
  TablePointsInForce in_force{t.interpolation, {}};
  for (const CurvePoint& p : t.points) in_force.c_deg.push_back(p.c_deg);
  return in_force;
}

bool has_point_at(const CurveTable& t, double c_deg) {
  return std::any_of(t.points.begin(), t.points.end(), [&](const CurvePoint& p) { return p.c_deg == c_deg; });
}

// The next table of a lobe keeps the points of the one in force (adding some where the
// corrected path breaks the bound between them), so a closed loop meets the same
// interpolation error again instead of a new one (docs/nc_output.md).
TEST(DefaultTable, KeepsThePointsOfTheTableInForceAndAddsWhereTheBoundBreaks) {
  for (bool allow_spline : {true, false}) {
    const TableChoiceSettings settings{0.5, 10.0, allow_spline};
    Result<CurveTable> first = write_default_table(analytic_path(4.0, 0.7), settings);
    ASSERT_TRUE(first.ok()) << first.error().message;
    const SampledPath corrected = with_bump(analytic_path(4.0, 0.7), 3.0, 4.0);
    Result<CurveTable> fresh = write_default_table(corrected, settings);
    ASSERT_TRUE(fresh.ok()) << fresh.error().message;
    const TablePointsInForce in_force = points_of(*first);
    Result<CurveTable> next = write_default_table(corrected, settings, {}, &in_force);
    ASSERT_TRUE(next.ok()) << next.error().message;
    EXPECT_EQ(next->interpolation, first->interpolation);
    for (const CurvePoint& p : first->points) EXPECT_TRUE(has_point_at(*next, p.c_deg)) << "C" << p.c_deg;
    EXPECT_GT(next->block_count(), first->block_count()) << "the bump breaks the bound between the old points";
    EXPECT_LE(next->error.max_abs_um, 0.5);
    EXPECT_LE(next->block_count(), 1.25 * fresh->block_count())
        << "first " << first->block_count() << " blocks, fresh " << fresh->block_count();
    EXPECT_NE(next->writer.find("table in force"), std::string::npos) << next->writer;
    // The points were chosen for the old path; X is the new path's.
    EXPECT_NEAR(next->error.max_abs_um, testing::ref_error_um(program_of(*next, {}), corrected), 1e-4);
  }
}

// As measure_job keeps them: C read back from the pushed program's text (3 decimals). A
// narrower widest segment since then splits the wide segments; a control that no longer
// takes CSPLINE gets a fresh G1 table instead of the spline's points.
TEST(DefaultTable, KeepsPointsReadBackFromTheProgramAndHonoursChangedSettings) {
  const SampledPath p = analytic_path(4.0, 0.7);
  Result<CurveTable> first = write_default_table(p, {});
  ASSERT_TRUE(first.ok()) << first.error().message;
  ASSERT_EQ(first->interpolation, Interpolation::kCubicSpline);
  Result<ParsedTable> read = parse_table_program(program_of(*first, {}), "pushed.spf");
  ASSERT_TRUE(read.ok()) << read.error().message;
  TablePointsInForce in_force{read->interpolation, {}};
  for (const CurvePoint& pt : read->points) in_force.c_deg.push_back(pt.c_deg);

  Result<CurveTable> narrower = write_default_table(p, {0.5, 5.0, true}, {}, &in_force);
  ASSERT_TRUE(narrower.ok()) << narrower.error().message;
  EXPECT_NE(narrower->writer.find("table in force"), std::string::npos) << narrower->writer;
  for (const CurvePoint& pt : first->points) EXPECT_TRUE(has_point_at(*narrower, pt.c_deg)) << "C" << pt.c_deg;
  for (size_t i = 1; i < narrower->points.size(); ++i) {
    EXPECT_LE(narrower->points[i].c_deg - narrower->points[i - 1].c_deg, 5.0 + 1e-9)
        << "C" << narrower->points[i].c_deg;
  }

  Result<CurveTable> g1_only = write_default_table(p, {0.5, 10.0, false}, {}, &in_force);
  ASSERT_TRUE(g1_only.ok()) << g1_only.error().message;
  EXPECT_EQ(g1_only->interpolation, Interpolation::kLinear);
  EXPECT_EQ(g1_only->writer.find("table in force"), std::string::npos) << g1_only->writer;
}

// Points grown to more than 1.25 times the fewest blocks (or never fit for this path) give
// way to a fresh choice: the fewest blocks again.
TEST(DefaultTable, StartsAfreshWhenThePointsInForceNeedTooManyBlocks) {
  const SampledPath p = analytic_path(4.0, 0.7);
  Result<CurveTable> fewest = write_default_table(p, {});
  Result<CurveTable> dense = write_linear_table(p, 0.5);
  ASSERT_TRUE(fewest.ok() && dense.ok());
  const TablePointsInForce too_many = points_of(*dense);
  Result<CurveTable> d = write_default_table(p, {}, {}, &too_many);
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_EQ(d->block_count(), fewest->block_count());
  EXPECT_EQ(d->writer, fewest->writer);

  // A table in force on another grid (C0.005) or not closing at C360 cannot be kept.
  for (const TablePointsInForce& bad : {TablePointsInForce{Interpolation::kLinear, {0.0, 0.005, 90.0, 180.0, 360.0}},
                                        TablePointsInForce{Interpolation::kLinear, {0.0, 90.0, 180.0, 270.0}}}) {
    Result<CurveTable> kept = write_table_at_points(p, bad);
    ASSERT_FALSE(kept.ok());
    EXPECT_EQ(kept.error().code, ErrorCode::kInvalidInput);
    Result<CurveTable> again = write_default_table(p, {}, {}, &bad);
    ASSERT_TRUE(again.ok()) << again.error().message;
    EXPECT_EQ(again->block_count(), fewest->block_count());
  }
}

}  // namespace
}  // namespace gaugeloop
