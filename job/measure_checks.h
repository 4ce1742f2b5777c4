// The measure job's checks before the gauge is read (measure_job.h declares the public ones:
// check_job_settings, check_name, check_nc_directory, open_store_for_push). Internal to job/.
#pragma once

#include "compensation/flat_probe.h"
#include "compensation/periodic_spline.h"
#include "core/result.h"
#include "job/measure_job.h"

namespace gaugeloop {

// What the checks before the gauge produce and the job goes on with.
struct Prepared {
  PeriodicSpline design;
  DesignReading reading;
};

// The names first (cheap, and a bad one must not reach a file name or the database), then the
// checks that need no gauge, so bad input costs no measurement: the design must make a table
// within the axis limits (a pin's geometry and its Y axis too), every template must render the
// design's programs, and the zones of the tolerances must fit the lobe.
Result<Prepared> check_names_and_prepare(const JobSettings& s);

}  // namespace gaugeloop
