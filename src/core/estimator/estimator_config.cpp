// The estimator's configuration: method names, and validation (the ranges of its parameter table,
// estimator_params_table.cpp, and the checks that involve more than one field).

#include "drill_pipe_pose/core/estimator/estimator_config.hpp"

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/estimator_params_table.hpp"

namespace drill_pipe_pose {

EstimatorMethod parseEstimatorMethod(const std::string& name, const std::string& source) {
  if (name == "ours") return EstimatorMethod::kOurs;
  if (name == "thesis_baseline") return EstimatorMethod::kThesisBaseline;
  fail(source, ": method = \"", name, "\" is not one of \"ours\", \"thesis_baseline\"");
}

const char* estimatorMethodName(EstimatorMethod m) {
  return m == EstimatorMethod::kOurs ? "ours" : "thesis_baseline";
}

void validateConfig(const EstimatorConfig& c) {
  // Every field against its range (the message names the key and the range).
  checkParamRanges(estimatorParamTable(), c, "estimator config");
  // Cross-field checks.
  for (int i = 0; i < 3; ++i)
    if (!(c.work_zone.min[i] < c.work_zone.max[i]))
      fail("estimator config: work_zone/min[", i, "] = ", c.work_zone.min[i],
           " must be < work_zone/max[", i, "] = ", c.work_zone.max[i]);
  if (c.pipe_types.empty())
    fail("estimator config: pipe_types is empty: name the pipe catalogue's entries an end may be "
         "(or [all])");
  // Throws naming the bad dimension.
  toolJointProfile(EndLabel::kBoxEnd, c.dims);
  toolJointProfile(EndLabel::kPinEnd, c.dims);
  if (!(c.cutout.max_range > c.cutout.min_range))
    fail("estimator config: cutout/max_range = ", c.cutout.max_range,
         " must be > cutout/min_range = ", c.cutout.min_range);
  if (c.profile_fit.max_points < c.axis_fit.min_points)
    fail("estimator config: profile_fit/max_points = ", c.profile_fit.max_points,
         " must be >= axis_fit/min_points = ", c.axis_fit.min_points);
  if (!(c.baseline.band_max_z > c.baseline.band_min_z))
    fail("estimator config: baseline/band_max_z = ", c.baseline.band_max_z,
         " must be > baseline/band_min_z = ", c.baseline.band_min_z);
}

}  // namespace drill_pipe_pose
