// `gaugeloop demo --speed-program` as a user runs it: the variable-speed camshaft paper's
// comparison, the loop at one grinding-point speed all round, then with the flanks slowed, and
// the three figures that compare them.
#include <gtest/gtest.h>

#include <cstdio>
#include <sstream>
#include <string>

#include "tests/support/cli.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

using testing::CommandResult;
using testing::run_command;

struct Pair {
  double program = -1.0;
  double constant = -1.0;
};

// The two numbers of the line starting with `prefix`, e.g. "speed program: flank Ra %lf um against %lf".
Pair figures(const std::string& output, const char* format) {
  std::istringstream lines(output);
  std::string line;
  Pair p;
  while (std::getline(lines, line)) {
    if (std::sscanf(line.c_str(), format, &p.program, &p.constant) == 2) return p;
  }
  return {};
}

// One compensation step each way, seeds fixed. The form error after a step sits within about
// 0.3 um of its floor either way (the gauge noise and the vibration), so "no worse" is held to
// 0.5 um here; docs/variable_speed.md has the figures over more seeds.
TEST(SpeedProgramDemo, SlowsTheFlanksForTheirFinishWithoutLosingForm) {
  testing::TempDir dir("speed-demo");
  const CommandResult r = run_command(
      "demo --iterations 1 --speed-program --time-scale 10 --seed 7 --machine-seed 11 "
      "--data-dir " +
      dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Pair cycle = figures(r.output, "speed program: cycle time %lf s against %lf s");
  const Pair ra = figures(r.output, "speed program: flank Ra %lf um against %lf um");
  const Pair form = figures(r.output, "speed program: form error %lf um against %lf um");
  ASSERT_GT(cycle.program, 0.0) << r.output;
  ASSERT_GT(ra.program, 0.0) << r.output;
  ASSERT_GT(form.program, 0.0) << r.output;
  // The paper's comparison: one grinding-point speed (8000 mm/min) against the flanks slowed to
  // 2000; slowing them costs cycle time.
  EXPECT_GT(cycle.constant, 0.5);
  EXPECT_GT(cycle.program, cycle.constant + 0.5);
  EXPECT_LT(cycle.program, 6.0);
  // The model's two points: 0.775 um at 2000 mm/min, 3.2 um at 8000; the flanks are ground at
  // most at those speeds, and the figure is taken where they are fastest (within the fitted range).
  EXPECT_LE(ra.program, 0.78);
  EXPECT_GT(ra.program, 0.7);
  EXPECT_LE(ra.constant, 3.2 + 0.005);
  EXPECT_GT(ra.constant, 3.0);
  EXPECT_NE(r.output.find("within the 2000..8000 mm/min it was fitted on"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("Ra is a model, not a measurement"), std::string::npos) << r.output;
  EXPECT_LT(form.program, form.constant + 0.5) << r.output;
  EXPECT_LT(form.program, 2.6) << r.output;
}

TEST(SpeedProgramDemo, RefusesAFlankSpeedOutOfRange) {
  testing::TempDir dir("speed-demo-bad");
  const CommandResult r =
      run_command("demo --speed-program --flank-speed-mm-per-min 0 --data-dir " + dir.path().string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--flank-speed-mm-per-min"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace gaugeloop
