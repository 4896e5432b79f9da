// The estimator's configuration: method names, and validation (the ranges of its parameter table,
// estimator_params_table.cpp, and the checks that involve more than one field).

#include "drill_pipe_pose/core/estimator/estimator_config.hpp"

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
  const auto take = [](double* b, double s, double d) {
    if (s != d) *b = s;
  };
  take(&base.tube_od, set.tube_od, def.tube_od);
  take(&base.tube_id, set.tube_id, def.tube_id);
  take(&base.tool_joint_od, set.tool_joint_od, def.tool_joint_od);
  take(&base.tool_joint_id, set.tool_joint_id, def.tool_joint_id);
  take(&base.elevator_taper_deg, set.elevator_taper_deg, def.elevator_taper_deg);
  take(&base.pin_tong_length, set.pin_tong_length, def.pin_tong_length);
  take(&base.box_tong_length, set.box_tong_length, def.box_tong_length);
  take(&base.pin_length, set.pin_length, def.pin_length);
  take(&base.pin_large_diameter, set.pin_large_diameter, def.pin_large_diameter);
  take(&base.pin_taper, set.pin_taper, def.pin_taper);
  take(&base.box_counterbore_diameter, set.box_counterbore_diameter,
       def.box_counterbore_diameter);
  take(&base.box_thread_depth, set.box_thread_depth, def.box_thread_depth);
  take(&base.threads_per_inch, set.threads_per_inch, def.threads_per_inch);
  take(&base.thread_height, set.thread_height, def.thread_height);
  take(&base.tube_length, set.tube_length, def.tube_length);
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
