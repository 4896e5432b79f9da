// The estimator's configuration: method names, and validation (the ranges of its parameter table,
// estimator_params_table.cpp, and the checks that involve more than one field).

#include "drill_pipe_pose/core/estimator/estimator_config.hpp"

#include <cmath>

#include "drill_pipe_pose/core/errors.hpp"
#include "drill_pipe_pose/core/estimator/estimator_params_table.hpp"
#include "drill_pipe_pose/core/pipe_catalog.hpp"

namespace drill_pipe_pose {

EstimatorMethod parseEstimatorMethod(const std::string& name, const std::string& source) {
  if (name == "ours") return EstimatorMethod::kOurs;
  if (name == "thesis_baseline") return EstimatorMethod::kThesisBaseline;
  fail(source, ": method = \"", name, "\" is not one of \"ours\", \"thesis_baseline\"");
}

const char* estimatorMethodName(EstimatorMethod m) {
  return m == EstimatorMethod::kOurs ? "ours" : "thesis_baseline";
}

namespace {

/// `base` with every field of `set` that differs from the defaults' (a tool_joint/* override).
ToolJointDimensions withOverrides(ToolJointDimensions base, const ToolJointDimensions& set) {
  const ToolJointDimensions def;
  for (const auto& [name, field] : toolJointNumericFields())
    if (set.*field != def.*field) base.*field = set.*field;
  if (set.threads != def.threads) base.threads = set.threads;
  return base;
}

}  // namespace

void resolvePipeTypes(EstimatorConfig* c, const PipeCatalog& catalog) {
  if (c->pipe_type.empty()) return;
  const std::string where = "estimator config (pipe catalogue " + catalog.path + ")";
  c->dims = withOverrides(catalog.at(c->pipe_type).dims, c->dims);
  validateDimensions(c->dims, where + ": tool_joint/type " + c->pipe_type + " with tool_joint/*");
  std::vector<std::string> names = c->pipe_types;
  if (names.empty())
    fail("estimator config: pipe_types is empty: name the pipe catalogue's entries an end may be "
         "(or [all])");
  if (names.size() == 1 && names[0] == "all") names = catalog.names();
  c->candidates.clear();
  bool has_start = false;
  for (const std::string& name : names) {
    if (name == "all")
      fail(where, ": pipe_types lists \"all\" among names: give [all] alone or the names");
    const PipeType& t = catalog.at(name);  // throws naming the catalogue and the known names
    for (const PipeCandidate& prev : c->candidates)
      if (prev.name == name) fail(where, ": pipe_types lists ", name, " twice");
    const bool start = name == c->pipe_type;
    has_start = has_start || start;
    c->candidates.push_back({name, start ? c->dims : t.dims});
  }
  if (!has_start)
    fail(where, ": tool_joint/type ", c->pipe_type,
         " is not among pipe_types (the type the models start from must be allowed)");
}

void validateConfig(const EstimatorConfig& c) {
  // Every field against its range (the message names the key and the range).
  checkParamRanges(estimatorParamTable(), c, "estimator config");
  // Cross-field checks.
  for (int i = 0; i < 3; ++i)
    if (!(c.work_zone.min[i] < c.work_zone.max[i]))
      fail("estimator config: work_zone/min[", i, "] = ", c.work_zone.min[i],
           " must be < work_zone/max[", i, "] = ", c.work_zone.max[i]);
  if (!c.instances.handling_point.empty() && c.instances.handling_point.size() != 3)
    fail("estimator config: instances/handling_point has ", c.instances.handling_point.size(),
         " values: give [x, y, z] in the world frame, or [] for none");
  for (double v : c.instances.handling_point)
    if (!std::isfinite(v)) fail("estimator config: instances/handling_point holds ", v);
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
