#pragma once
// Every stage of the estimator pipeline, for tests and tools that use several (each stage's own
// header is enough for one). Everything is in the world frame [m] unless the name says otherwise.

#include "drill_pipe_pose/core/estimator/axis_fit.hpp"
#include "drill_pipe_pose/core/estimator/carving.hpp"
#include "drill_pipe_pose/core/estimator/cutout.hpp"
#include "drill_pipe_pose/core/estimator/instances.hpp"
#include "drill_pipe_pose/core/estimator/profile_model.hpp"
#include "drill_pipe_pose/core/estimator/profile_registration.hpp"
#include "drill_pipe_pose/core/estimator/seen_through.hpp"
#include "drill_pipe_pose/core/estimator/support_plane.hpp"
